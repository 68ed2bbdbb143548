"""The self-contained HTML page of the virtual pendulum (inline SVG and JavaScript, no network).

The page draws, from the run's samples, the cart on its 750 mm track and the pendulum in
the plant's conventions (x positive to the left, theta from hanging), a time slider, a
play/pause button and the traces of the angle, the cart position and the input (named in
the page's data as the run names them) with a cursor. ``window.pendc`` exposes
the current frame and the drawn positions so that a browser test can check them.
"""

PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>pendc: virtual pendulum</title>
<style>
body { font-family: sans-serif; margin: 16px; color: #222; }
#wrap { display: flex; flex-wrap: wrap; gap: 16px; align-items: flex-start; }
#controls { margin: 8px 0; display: flex; gap: 12px; align-items: center; }
#slider { width: 420px; }
.trace { fill: none; stroke-width: 1.2; }
.label { font-size: 11px; fill: #555; }
</style></head><body>
<h3>pendc virtual pendulum: __TITLE__</h3>
<div id="controls">
  <button id="play" type="button">Play</button>
  <input id="slider" type="range" min="0" max="0" step="1" value="0" aria-label="time">
  <span id="clock">t = 0.000 s</span>
  <label>speed <select id="speed"><option>0.25</option><option>0.5</option><option selected>1</option>
  <option>2</option></select></label>
</div>
<div id="wrap">
<svg id="scene" width="640" height="440" viewBox="0 0 640 440" role="img" aria-label="cart and pendulum">
  <rect x="0" y="0" width="640" height="440" fill="#f7f7f4"/>
  <line id="track" x1="20" y1="236" x2="620" y2="236" stroke="#444" stroke-width="4"/>
  <rect x="14" y="212" width="6" height="36" fill="#b22"/><rect x="620" y="212" width="6" height="36" fill="#b22"/>
  <text class="label" x="20" y="266">+x (left) | track 750 mm</text>
  <text class="label" x="560" y="266">-x (right)</text>
  <rect id="cart" x="0" y="216" width="60" height="28" rx="4" fill="#3a6ea5"/>
  <line id="rod" x1="0" y1="0" x2="0" y2="0" stroke="#222" stroke-width="5" stroke-linecap="round"/>
  <circle id="bob" cx="0" cy="0" r="13" fill="#d2691e"/>
  <circle id="pivot" cx="0" cy="0" r="4" fill="#fff" stroke="#222"/>
  <text id="modeText" class="label" x="20" y="30"></text>
</svg>
<svg id="traces" width="420" height="440" viewBox="0 0 420 440" role="img" aria-label="traces"></svg>
</div>
<script>
"use strict";
const D = __DATA__;
const N = D.t.length, W = 640, TRACK = 0.75, SCALE = (W - 40) / TRACK, CX = W / 2, PY = 230;
const ROD = 0.22, scene = {};   // pivot to bob centre (m), drawn to the track's scale
["cart", "rod", "bob", "pivot", "modeText"].forEach(id => scene[id] = document.getElementById(id));
const slider = document.getElementById("slider"), clock = document.getElementById("clock");
const play = document.getElementById("play"), speed = document.getElementById("speed");
slider.max = String(N - 1);
const state = { frame: 0, playing: false, cartX: 0, bobX: 0, bobY: 0 };
window.pendc = state;

function draw(k) {
  state.frame = k;
  const x = D.cart[k], th = D.angle[k];
  const px = CX - SCALE * x;                       // +x is to the left
  const bx = px + SCALE * ROD * Math.sin(th);      // bob at (x - l sin th, -l cos th), +x left
  const by = PY + SCALE * ROD * Math.cos(th);
  scene.cart.setAttribute("x", (px - 30).toFixed(2));
  scene.rod.setAttribute("x1", px.toFixed(2)); scene.rod.setAttribute("y1", PY);
  scene.rod.setAttribute("x2", bx.toFixed(2)); scene.rod.setAttribute("y2", by.toFixed(2));
  scene.bob.setAttribute("cx", bx.toFixed(2)); scene.bob.setAttribute("cy", by.toFixed(2));
  scene.pivot.setAttribute("cx", px.toFixed(2)); scene.pivot.setAttribute("cy", PY);
  scene.modeText.textContent = D.mode[k] ? "controller: " + D.mode[k] : "";
  state.cartX = px; state.bobX = bx; state.bobY = by;
  slider.value = String(k);
  clock.textContent = "t = " + D.t[k].toFixed(3) + " s";
  cursors.forEach(c => { const cx = tx(D.t[k]).toFixed(2); c.setAttribute("x1", cx); c.setAttribute("x2", cx); });
}

const T0 = D.t[0], T1 = D.t[N - 1] > D.t[0] ? D.t[N - 1] : D.t[0] + 1;
function tx(t) { return 50 + (t - T0) / (T1 - T0) * 360; }
const svgNS = "http://www.w3.org/2000/svg", traces = document.getElementById("traces"), cursors = [];
function panel(name, values, top, colour) {
  const finite = values.filter(v => Number.isFinite(v));
  if (!finite.length) return;
  let lo = Math.min(...finite), hi = Math.max(...finite);
  if (hi - lo < 1e-9) { lo -= 1; hi += 1; }
  const h = 124, y = v => top + h - (v - lo) / (hi - lo) * h;
  let d = "";
  values.forEach((v, i) => { if (Number.isFinite(v)) d += (d ? "L" : "M") + tx(D.t[i]).toFixed(1) + "," + y(v).toFixed(1); });
  const p = document.createElementNS(svgNS, "path");
  p.setAttribute("d", d); p.setAttribute("class", "trace"); p.setAttribute("stroke", colour);
  traces.appendChild(p);
  const box = document.createElementNS(svgNS, "rect");
  Object.entries({x: 50, y: top, width: 360, height: h, fill: "none", stroke: "#ccc"}).forEach(([a, b]) => box.setAttribute(a, b));
  traces.appendChild(box);
  [[name, 2, top + 10], [hi.toPrecision(3), 2, top + 22], [lo.toPrecision(3), 2, top + h]].forEach(([s, lx, ly]) => {
    const t = document.createElementNS(svgNS, "text");
    t.setAttribute("x", lx); t.setAttribute("y", ly); t.setAttribute("class", "label"); t.textContent = s;
    traces.appendChild(t);
  });
  const c = document.createElementNS(svgNS, "line");
  Object.entries({y1: top, y2: top + h, stroke: "#b22", "stroke-width": 1}).forEach(([a, b]) => c.setAttribute(a, b));
  traces.appendChild(c); cursors.push(c);
}
panel(D.names.angle + " (" + D.units.angle + ")", D.angle, 8, "#1f77b4");
panel(D.names.cart + " (" + D.units.cart + ")", D.cart, 152, "#222");
panel(D.names.input + " (V)", D.input, 296, "#2ca02c");

let last = null;
function tick(now) {
  if (!state.playing) { last = null; return; }
  if (last !== null) {
    const target = D.t[state.frame] + (now - last) / 1000 * Number(speed.value);
    let k = state.frame;
    while (k < N - 1 && D.t[k + 1] <= target) k++;
    if (k >= N - 1) { state.playing = false; play.textContent = "Play"; }
    if (k !== state.frame) draw(k);
  }
  last = now;
  requestAnimationFrame(tick);
}
play.addEventListener("click", () => {
  if (!state.playing && state.frame >= N - 1) draw(0);
  state.playing = !state.playing; play.textContent = state.playing ? "Pause" : "Play";
  if (state.playing) requestAnimationFrame(tick);
});
slider.addEventListener("input", () => draw(Number(slider.value)));
window.pendcShow = draw;
draw(0);
</script></body></html>
"""
