"""The lockstep loop served to one external controller over TCP on the loopback.

Protocol (ASCII lines ending in ``\\n``; see docs/hil.md):

    server: PENDC-HIL 1 period=0.001 periods=12001 <state>_count=<resolution> ...
                                                one <state>_count per encoder, in the plant
                                                interface's order (cart-pendulum: x_count=2.5e-06
                                                theta_count=0.000314159...), then per sampled
                                                converter <state>_code=<lsb> <state>_lo=<low>
    server: S <k> <t> <count> ... <code> ...    one line per control period, k = 0, 1, ...:
                                                every encoder's count, in the same order, then
                                                every converter's code (the state reads
                                                low + (code + 1/2) lsb)
    client: <volts>                             one decimal number per S line
    server: END complete                        after the last period, then the server closes
            END stopped <reason>                on a timeout, a malformed answer or a plant error

Counts are the ×4 encoder counts since reset (signs as the plant interface's states, as its plant
file declares them). The answer is clamped to the input's range and quantised by the 12-bit DAC.
Every wait is bounded by the timeout; the server accepts one client and stops by itself.
"""

from __future__ import annotations

import ipaddress
import math
import socket

from ..errors import PendcError
from .loop import HilRun, run_closed_loop

PROTOCOL_VERSION = 1
MAX_LINE = 256   # bytes: an answer is one number; anything longer is malformed


def parse_loopback_address(text: str) -> tuple[str, int]:
    """``HOST:PORT`` with HOST a loopback address (127.x.y.z, ::1 as [::1], or localhost)."""
    host, sep, port_text = text.rpartition(":")
    if not sep or not host:
        raise PendcError(f"--serve needs HOST:PORT on the loopback, e.g. 127.0.0.1:5555, got {text!r}")
    host = host.strip("[]")
    if host == "localhost":
        host = "127.0.0.1"
    try:
        ip = ipaddress.ip_address(host)
    except ValueError:
        raise PendcError(f"--serve: {host!r} is not an IP address (use 127.0.0.1)") from None
    if not ip.is_loopback:
        raise PendcError(f"--serve: {host} is not a loopback address; pendc serves only on this machine")
    try:
        port = int(port_text)
    except ValueError:
        raise PendcError(f"--serve: port must be a number, got {port_text!r}") from None
    if not 0 <= port <= 65535:
        raise PendcError(f"--serve: port must be in 0..65535, got {port}")
    return str(ip), port


class ClientLink:
    """One connected controller: send a period's measurement, read its answer (bounded waits)."""

    def __init__(self, conn: socket.socket, timeout: float):
        self.conn = conn
        self.conn.settimeout(timeout)
        self.timeout = timeout
        self.reader = conn.makefile("rb")
        self.k = 0

    def send(self, text: str) -> None:
        """Send one line; a vanished client is a PendcError."""
        try:
            self.conn.sendall((text + "\n").encode("ascii"))
        except OSError as exc:
            raise PendcError(f"the controller disconnected ({exc.strerror or exc})") from None

    def answer(self, meas) -> float:
        """The volts the client answers to this period's measurement."""
        self.send(f"S {self.k} {meas.t:.6f} " + " ".join(str(c) for _, c in (*meas.counts, *meas.codes)))
        self.k += 1
        try:
            raw = self.reader.readline(MAX_LINE + 1)
        except (TimeoutError, socket.timeout):
            raise PendcError(f"no answer from the controller within {self.timeout:g} s") from None
        except OSError as exc:
            raise PendcError(f"the controller disconnected ({exc.strerror or exc})") from None
        if not raw:
            raise PendcError("the controller closed the connection")
        if len(raw) > MAX_LINE or not raw.endswith(b"\n"):
            raise PendcError(f"malformed answer from the controller: line longer than {MAX_LINE} bytes")
        text = raw.decode("ascii", errors="replace").strip()
        try:
            volts = float(text)
        except ValueError:
            raise PendcError(f"malformed answer from the controller: {text[:40]!r} is not a number of volts") from None
        if not math.isfinite(volts):
            raise PendcError(f"malformed answer from the controller: {text!r} is not finite")
        return volts

    def close(self, run: HilRun) -> None:
        """Tell the client how the run ended and hang up."""
        try:
            self.send("END complete" if run.stopped is None else f"END stopped {run.stopped}")
        except PendcError:
            pass
        self.reader.close()
        self.conn.close()


def serve_loop(plant, address: tuple[str, int], seconds: float, period: float = 1e-3, plant_name: str = "",
               timeout: float = 10.0, progress=None, announce=None, count_origin: dict | None = None) -> HilRun:
    """Listen on ``address`` (loopback), run the loop with the first client as the controller.

    ``announce(text)`` gets the line saying where the server listens (its real port if
    port 0 was asked for). A client that does not connect within ``timeout`` is an error;
    a client that stops answering ends the run with the rows so far. ``count_origin``: as
    :func:`~pendc.hil.loop.run_closed_loop` takes it (a plant started elsewhere than at 0).
    """
    host, port = address
    if not ipaddress.ip_address(host).is_loopback:
        raise PendcError(f"--serve: {host} is not a loopback address")
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as listener:
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            listener.bind((host, port))
        except OSError as exc:
            raise PendcError(f"--serve: cannot listen on {host}:{port} ({exc.strerror or exc})") from None
        listener.listen(1)
        listener.settimeout(timeout)
        real_port = listener.getsockname()[1]
        if announce is not None:
            announce(f"pendc: serving on {host}:{real_port}, waiting {timeout:g} s for a controller")
        try:
            conn, _ = listener.accept()
        except (TimeoutError, socket.timeout):
            raise PendcError(f"no controller connected to {host}:{real_port} within {timeout:g} s") from None
    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    link = ClientLink(conn, timeout)
    n_rows = int(round(seconds / period)) + 1
    link.send(f"PENDC-HIL {PROTOCOL_VERSION} period={period:g} periods={n_rows} "
              + " ".join([f"{e.state}_count={e.resolution!r}" for e in plant.ports.encoders]
                         + [f"{a.state}_code={a.resolution!r} {a.state}_lo={a.lo!r}" for a in plant.ports.adcs]))
    run = run_closed_loop(plant, None, seconds, period=period, plant_name=plant_name, progress=progress,
                          answer=link.answer, count_origin=count_origin)
    link.close(run)
    return run
