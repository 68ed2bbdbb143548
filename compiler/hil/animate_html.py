"""The self-contained HTML page of a run (inline SVG and JavaScript, no network).

The page draws, per frame, the points and lines :mod:`pendc.hil.drawing` laid out from the
plant file's ``[drawing]`` (already in pixels: the script does no geometry), a time slider,
a play/pause button, a speed choice (times ``D.slow``, the run's slow motion) and a trace per
recorded position and the input, with a cursor.
``window.pendc`` exposes the current frame and each drawn point's place so that a browser
test can check them.
"""

PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>pendc: __TITLE__</title>
<style>
body { font-family: sans-serif; margin: 16px; color: #222; }
#wrap { display: flex; flex-wrap: wrap; gap: 16px; align-items: flex-start; }
#controls { margin: 8px 0; display: flex; gap: 12px; align-items: center; }
#slider { width: 420px; }
.trace { fill: none; stroke-width: 1.2; }
.label { font-size: 11px; fill: #555; }
</style></head><body>
<h3>pendc: __TITLE__</h3>
<div id="controls">
  <button id="play" type="button">Play</button>
  <input id="slider" type="range" min="0" max="0" step="1" value="0" aria-label="time">
  <span id="clock">t = 0.000 s</span>
  <label>speed <select id="speed"><option>0.25</option><option>0.5</option><option selected>1</option>
  <option>2</option></select></label>
  <span id="pace" class="label"></span>
</div>
<div id="wrap">
<svg id="scene" width="640" height="440" viewBox="0 0 640 440" role="img" aria-label="the plant">
  <rect x="0" y="0" width="640" height="440" fill="#f7f7f4"/>
  <g id="joins"></g><g id="dots"></g>
  <text id="modeText" class="label" x="20" y="30"></text>
</svg>
<svg id="traces" width="420" height="440" viewBox="0 0 420 440" role="img" aria-label="traces"></svg>
</div>
<script>
"use strict";
const D = __DATA__;
const N = D.t.length, svgNS = "http://www.w3.org/2000/svg";
const slider = document.getElementById("slider"), clock = document.getElementById("clock");
const play = document.getElementById("play"), speed = document.getElementById("speed");
const modeText = document.getElementById("modeText");
slider.max = String(N - 1);
// the simulated time played so far: a tick of a slowed run moves it less than one frame
const state = { frame: 0, playing: false, points: {}, clock: D.t[0] };
if (D.slow !== 1) document.getElementById("pace").textContent = "played " + D.slow + "\u00d7 slower than real time";
window.pendc = state;
function make(tag, parent, attrs) {
  const e = document.createElementNS(svgNS, tag);
  Object.entries(attrs).forEach(([a, b]) => e.setAttribute(a, b));
  document.getElementById(parent).appendChild(e);
  return e;
}
const joins = D.lines.map(([a, b]) => [a, b, make("line", "joins", {id: "line-" + a + "-" + b, stroke: "#222",
  "stroke-width": 5, "stroke-linecap": "round"})]);
const dots = Object.keys(D.points).map(name => [name, make("circle", "dots", {id: "pt-" + name, r: 7,
  fill: "#d2691e", stroke: "#222"})]);

function draw(k) {
  state.frame = k;
  dots.forEach(([name, dot]) => {
    const x = D.points[name][0][k], y = D.points[name][1][k];
    dot.setAttribute("cx", x); dot.setAttribute("cy", y);
    state.points[name] = [x, y];
  });
  joins.forEach(([a, b, line]) => {
    line.setAttribute("x1", D.points[a][0][k]); line.setAttribute("y1", D.points[a][1][k]);
    line.setAttribute("x2", D.points[b][0][k]); line.setAttribute("y2", D.points[b][1][k]);
  });
  modeText.textContent = D.mode[k] ? "controller: " + D.mode[k] : "";
  slider.value = String(k);
  clock.textContent = "t = " + D.t[k].toFixed(D.decimals) + " s";
  cursors.forEach(c => { const cx = tx(D.t[k]).toFixed(2); c.setAttribute("x1", cx); c.setAttribute("x2", cx); });
}

const T0 = D.t[0], T1 = D.t[N - 1] > D.t[0] ? D.t[N - 1] : D.t[0] + 1;
function tx(t) { return 50 + (t - T0) / (T1 - T0) * 360; }
const traces = document.getElementById("traces"), cursors = [];
function panel(name, values, top, colour) {
  const finite = values.filter(v => Number.isFinite(v));
  if (!finite.length) return;
  let lo = Math.min(...finite), hi = Math.max(...finite);
  if (hi - lo < 1e-9) { lo -= 1; hi += 1; }
  const h = H, y = v => top + h - (v - lo) / (hi - lo) * h;
  let d = "";
  values.forEach((v, i) => { if (Number.isFinite(v)) d += (d ? "L" : "M") + tx(D.t[i]).toFixed(1) + "," + y(v).toFixed(1); });
  const p = document.createElementNS(svgNS, "path");
  p.setAttribute("d", d); p.setAttribute("class", "trace"); p.setAttribute("stroke", colour);
  traces.appendChild(p);
  const box = document.createElementNS(svgNS, "rect");
  Object.entries({x: 50, y: top, width: 360, height: h, fill: "none", stroke: "#ccc"}).forEach(([a, b]) => box.setAttribute(a, b));
  traces.appendChild(box);
  // digits enough to tell the ends apart (a sink at 322.89..323.21 K read "323" at both)
  const dig = Math.min(12, Math.max(3, Math.ceil(Math.log10(Math.max(Math.abs(hi), Math.abs(lo)) / (hi - lo))) + 2));
  [[name, 2, top + 10], [hi.toPrecision(dig), 2, top + 22], [lo.toPrecision(dig), 2, top + h]].forEach(([s, lx, ly]) => {
    const t = document.createElementNS(svgNS, "text");
    Object.entries({x: lx, y: ly, class: "label"}).forEach(([a, b]) => t.setAttribute(a, b));
    t.textContent = s;
    traces.appendChild(t);
  });
  const c = document.createElementNS(svgNS, "line");
  Object.entries({y1: top, y2: top + h, stroke: "#b22", "stroke-width": 1}).forEach(([a, b]) => c.setAttribute(a, b));
  traces.appendChild(c); cursors.push(c);
}
const H = 124, GAP = 20, colours = ["#1f77b4", "#222", "#2ca02c", "#9467bd", "#8c564b", "#e377c2"];
traces.setAttribute("height", D.traces.length * (H + GAP) + 8);
traces.setAttribute("viewBox", "0 0 420 " + (D.traces.length * (H + GAP) + 8));
D.traces.forEach((tr, i) => panel(tr.name + (tr.unit ? " (" + tr.unit + ")" : ""), tr.values, 8 + i * (H + GAP),
  colours[i % colours.length]));

let last = null;
function tick(now) {
  if (!state.playing) { last = null; return; }
  if (last !== null) {
    state.clock += (now - last) / 1000 * Number(speed.value) / D.slow;
    let k = state.frame;
    while (k < N - 1 && D.t[k + 1] <= state.clock) k++;
    if (k >= N - 1) { state.playing = false; play.textContent = "Play"; }
    if (k !== state.frame) draw(k);
  }
  last = now;
  requestAnimationFrame(tick);
}
play.addEventListener("click", () => {
  if (!state.playing && state.frame >= N - 1) draw(0);
  if (!state.playing) state.clock = D.t[state.frame];
  state.playing = !state.playing; play.textContent = state.playing ? "Pause" : "Play";
  if (state.playing) requestAnimationFrame(tick);
});
function show(k) { state.clock = D.t[k]; draw(k); }
slider.addEventListener("input", () => show(Number(slider.value)));
window.pendcShow = show;
draw(0);
</script></body></html>
"""
