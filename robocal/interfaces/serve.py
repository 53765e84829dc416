"""``robocal serve``: a model answering a controller point by point over TCP.

One request per line, exactly one answer line per line received, in the units and frames of
``robocal compensate``'s files (mm, degrees; targets in the measurement frame; the answer's
x, y, z, rx, ry, rz in the robot base frame with the robot file's tool, the controller's FK of
the joint command).

* JSON lines (the default): ``{"x", "y", "z", "rx", "ry", "rz", "q": [posture hint, deg]}``
  (``q`` optional) in, ``{"q": [...], "x", "y", "z", "rx", "ry", "rz", "in_domain",
  "bound95_mm"}`` out.
* CSV lines (``--format csv``): ``x,y,z,rx,ry,rz[,q1..qN]`` in, ``q1..qN,x,y,z,rx,ry,rz,
  in_domain,bound95_mm`` out (in_domain 1/0, empty when unknown; bound95_mm, the model's 95 %
  bound on the position error there as ``compensate`` writes it (:mod:`robocal.methods.bound`),
  empty when the model file stores none).

Every bad request gets one ``{"error": "..."}`` line (in both formats) and the connection goes
on.  Bounded everywhere: a line longer than MAX_LINE bytes is discarded as it arrives (one
error line when its end comes), at most MAX_CLIENTS connections at once, a client idle for
IDLE_TIMEOUT seconds or not reading its answers for WRITE_TIMEOUT seconds is disconnected.
The model is computed in the event loop's thread: one request at a time, which is what the
numbers need (numpy and the GIL) and keeps every answer equal to ``compensate``'s.

The server is standard-library asyncio; SIGTERM and SIGINT stop it cleanly (exit 0), with a
summary of requests, errors and latencies on stderr.
"""
import asyncio
import json
import math
import signal
import sys
import time
import warnings
from collections import deque

import numpy as np

from ..errors import RobocalError
from ..io.units import ONE_TURN, RADIAN_HALF_TURN, check_angles, looks_like_radians
from ..spatial import pose_to_xyz_rpy
from .jobs import load_fitted

# Longest request line accepted, bytes (without its newline).
MAX_LINE = 64 * 1024
# Bytes read from a socket at a time.
READ_CHUNK = 65536
MAX_CLIENTS = 64
IDLE_TIMEOUT = 300.0  # s without a byte from a client
WRITE_TIMEOUT = 30.0  # s for a client to take its answers
# Requests beyond these are refused as absurd: positions in mm, angles in degrees.
MAX_POSITION = 1e6
MAX_ANGLE = 1e4
# Latencies kept for the summary (the most recent ones).
LATENCIES_KEPT = 1_000_000
FORMATS = ("json", "csv")
CARTESIAN = ("x", "y", "z", "rx", "ry", "rz")


class BadRequest(Exception):
    """A request that cannot be answered; the message goes back to the client."""


def _number(value, name, bound):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise BadRequest(f"{name} must be a number, got {json.dumps(value)[:40]}")
    try:
        value = float(value)
    except OverflowError:  # a whole number of hundreds of digits
        raise BadRequest(f"{name} is absurdly large") from None
    if not math.isfinite(value):
        raise BadRequest(f"{name} must be finite, got {value}")
    if abs(value) > bound:
        raise BadRequest(f"{name} = {value:g} is absurd (|{name}| <= {bound:g} expected)")
    return value


class Answerer:
    """A model file loaded once; :meth:`answer` turns one request line (bytes, without its
    newline) into (one answer line (bytes, with its newline), whether it answers or refuses)."""

    def __init__(self, model_path, fmt="json"):
        if fmt not in FORMATS:
            raise RobocalError(f"--format must be one of {', '.join(FORMATS)}, got {fmt!r}")
        self.fmt = fmt
        self.model, self.fitted = load_fitted(model_path)
        self.robot = self.model.kinematics  # the robot file: file units of the joints
        self.n_joints = self.robot.n_joints
        self._revolute = self.robot.revolute.tolist()
        self.compensator = self.fitted.compensator_
        self.domain = self.fitted.domain_
        # A compensator class with a one-target path (Compensator, DomainFallback); anything
        # else is asked as a batch of one.
        self._single = callable(getattr(type(self.compensator), "command", None))

    # ------------------------------------------------------------------ parsing
    def parse(self, line):
        """(xyz (3,), rxyz (3,) deg, hint (n,) deg or None) of a request line."""
        try:
            text = line.decode("utf-8").strip()
        except UnicodeDecodeError:
            raise BadRequest("the request is not UTF-8 text") from None
        if not text:
            raise BadRequest("empty line: send one request per line")
        return self._parse_csv(text) if self.fmt == "csv" else self._parse_json(text)

    def _parse_json(self, text):
        try:
            request = json.loads(text)
        except (ValueError, RecursionError) as why:
            raise BadRequest(f"not JSON: {str(why)[:80]}") from None
        if not isinstance(request, dict):
            raise BadRequest('a request is one JSON object {"x", "y", "z", "rx", "ry", "rz", "q"}')
        missing = [name for name in CARTESIAN if name not in request]
        if missing:
            raise BadRequest(f"missing field{'s' if len(missing) > 1 else ''} {', '.join(missing)}")
        values = [_number(request[name], name, MAX_POSITION if i < 3 else MAX_ANGLE)
                  for i, name in enumerate(CARTESIAN)]
        hint = request.get("q")
        if hint is not None:
            if not isinstance(hint, list) or len(hint) != self.n_joints:
                raise BadRequest(f"q must be a list of {self.n_joints} joint values (deg; mm for prismatic joints)")
            hint = [_number(v, f"q{i + 1}", MAX_ANGLE) for i, v in enumerate(hint)]
        return values[:3], values[3:], hint

    def _parse_csv(self, text):
        cells = text.split(",")
        if len(cells) not in (6, 6 + self.n_joints):
            raise BadRequest(f"a CSV request is x,y,z,rx,ry,rz or x,y,z,rx,ry,rz,q1..q{self.n_joints}: "
                             f"{len(cells)} values")
        names = list(CARTESIAN) + [f"q{i + 1}" for i in range(self.n_joints)]
        values = []
        for i, cell in enumerate(cells):
            try:
                value = float(cell)
            except ValueError:
                raise BadRequest(f"{names[i]} is not a number: {cell.strip()[:40]!r}") from None
            values.append(_number(value, names[i], MAX_POSITION if i < 3 else MAX_ANGLE))
        return values[:3], values[3:6], (values[6:] or None)

    # ------------------------------------------------------------------ answering
    def compute(self, xyz, rxyz, hint):
        """The answer's fields for one target, as ``compensate`` writes them."""
        # The rx, ry, rz meet the one test of typed angles (robocal.io.units), as a targets file's
        # do: radians would be answered for another orientation without a word.  Beyond half a
        # turn they cannot be radians (the usual request, rx = 180, is decided on floats).
        if max(map(abs, rxyz)) <= RADIAN_HALF_TURN:
            check_angles(rxyz, "the rx, ry, rz of the request", fix="send them in degrees")
        pose = target_pose(xyz, rxyz)
        revolute_hint = None if hint is None else [v for v, r in zip(hint, self._revolute) if r]
        # A joint beyond one turn cannot be in radians: the usual hint is decided on floats
        # (the array test costs some 3 us a request).
        if revolute_hint and max(map(abs, revolute_hint)) <= ONE_TURN and looks_like_radians(revolute_hint, ONE_TURN):
            # The one test of typed angles (robocal.io.units), as for a target file's hints: a
            # posture in radians would pick another arm branch without a word.
            raise BadRequest("q looks like radians (every joint within one turn, not whole degrees), but robocal "
                             "reads degrees: send the posture hint in degrees")
        # The robot file's units (deg; mm for prismatic joints) as joints_from_file converts
        # them (the same factor), on floats: the array call costs more than the conversion.
        hint_q = None if hint is None else np.array(
            [math.radians(v) if r else v for v, r in zip(hint, self._revolute)])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # Kriging's extrapolation note: the domain says it
            if self._single:
                result = self.compensator.command(pose, hint_q)
            else:
                result = self.compensator.commands(pose[None], hint=None if hint_q is None else hint_q[None])
            if not result.success[0]:
                raise BadRequest("unreachable: the calibrated robot cannot reach this target within its joint "
                                 "limits (is it in the measurement frame, in mm and degrees?)")
            q = result.q[0]
            # One configuration: the domain's and the bound's one-row paths, prepared once
            # (equal to check and predict of that row; the batch costs some 0.5 ms here).
            in_domain = None if self.domain is None else self.domain.inside_one(q, pose[:3, 3])
            bound = None
            if self.fitted.bound_ is not None:
                bound = self.fitted.bound_.predict_one(q, True if in_domain is None else in_domain)
        joints = [math.degrees(v) if r else v for v, r in zip(q.tolist(), self._revolute)]
        return {"q": joints, **dict(zip(CARTESIAN, answer_xyz_rpy(result.corrected[0]))),
                "in_domain": in_domain, "bound95_mm": bound}

    def answer(self, line):
        """(answer line, True) for one request line, or (error line, False); never raises."""
        try:
            fields = self.compute(*self.parse(line))
        except BadRequest as why:
            return error_line(str(why)), False
        except RobocalError as why:
            return error_line(str(why)), False
        except Exception as why:  # noqa: BLE001 - a request must never stop the server
            return error_line(f"internal error ({type(why).__name__}): {str(why)[:200]}"), False
        if self.fmt == "csv":
            numbers = fields["q"] + [fields[name] for name in CARTESIAN]
            domain = "" if fields["in_domain"] is None else str(int(fields["in_domain"]))
            bound = "" if fields["bound95_mm"] is None else repr(fields["bound95_mm"])
            return (",".join(repr(v) for v in numbers) + f",{domain},{bound}\n").encode(), True
        return (json.dumps(fields) + "\n").encode(), True


def target_pose(xyz, rxyz):
    """The (4, 4) pose of one request: ``xyz`` (3 floats, mm) and ``rxyz`` (3 floats, deg),
    R = Rz(rz) Ry(ry) Rx(rx) as :func:`robocal.spatial.compose_pose` builds it (equal to
    rounding), on floats: for one pose that batch machinery costs several times the formula."""
    rx, ry, rz = (math.radians(a) for a in rxyz)
    cx, sx, cy, sy, cz, sz = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry), math.cos(rz), math.sin(rz)
    return np.array([[cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx, xyz[0]],
                     [sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx, xyz[1]],
                     [-sy, cy * sx, cy * cx, xyz[2]],
                     [0.0, 0.0, 0.0, 1.0]])


def answer_xyz_rpy(pose):
    """x, y, z (mm) and rx, ry, rz (deg) of one (4, 4) pose, as
    :func:`robocal.spatial.pose_to_xyz_rpy` gives them (equal to rounding; the same steps:
    pitch from a well-conditioned atan2, roll from the last row, yaw from what is left), on
    floats."""
    (m00, m01, m02, x), (m10, m11, m12, y), (m20, m21, m22, z) = pose[:3].tolist()
    pitch = math.atan2(-m20, math.hypot(m00, m10))
    roll = math.atan2(m21, m22)
    ca, sa, cb, sb = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    # The first column of R Rx(roll)ᵀ Ry(pitch)ᵀ: Rz(yaw)'s.
    yaw = math.atan2(m10 * cb + (m11 * sa + m12 * ca) * sb, m00 * cb + (m01 * sa + m02 * ca) * sb)
    return [x, y, z, math.degrees(roll), math.degrees(pitch), math.degrees(yaw)]


def error_line(message):
    return (json.dumps({"error": message}) + "\n").encode()


class Stats:
    """Requests, errors and latencies (s) over the server's life, and per client."""

    def __init__(self):
        self.requests = self.errors = self.clients = 0
        self.latencies = deque(maxlen=LATENCIES_KEPT)

    def summary(self):
        text = f"{self.requests} requests, {self.errors} errors, {self.clients} clients"
        if self.latencies:
            ms = np.percentile(np.array(self.latencies) * 1e3, [50, 90, 99, 100])
            text += ", latency ms p50 {:.3f} p90 {:.3f} p99 {:.3f} max {:.3f}".format(*ms)
        return text


class Server:
    """The asyncio server around an :class:`Answerer`."""

    def __init__(self, answerer, log=None):
        self.answerer = answerer
        self.stats = Stats()
        self.log = log or (lambda text: print(text, file=sys.stderr, flush=True))
        self._open = set()
        self._tasks = set()

    async def handle(self, reader, writer):
        peer = writer.get_extra_info("peername")
        name = f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) else str(peer)
        if len(self._open) >= MAX_CLIENTS:
            writer.write(error_line(f"server busy: {MAX_CLIENTS} clients already connected"))
            await _close(writer)
            self.log(f"client {name}: refused (busy)")
            return
        self._open.add(writer)
        task = asyncio.current_task()
        self._tasks.add(task)
        self.stats.clients += 1
        started, requests, errors, ended = time.monotonic(), 0, 0, "disconnected"
        try:
            async for line in _lines(reader):
                begun = time.perf_counter()
                if line is None:
                    answer, ok = error_line(f"line longer than {MAX_LINE} bytes: discarded"), False
                else:
                    answer, ok = self.answerer.answer(line)
                writer.write(answer)
                # Usually the socket takes the answer at once: nothing to wait for (a wait_for
                # costs a task per request, some 30 us on this machine under load).
                if writer.transport.get_write_buffer_size():
                    await asyncio.wait_for(writer.drain(), WRITE_TIMEOUT)
                self.stats.latencies.append(time.perf_counter() - begun)
                requests += 1
                errors += not ok
        except asyncio.TimeoutError:
            ended = "timed out"
        except (ConnectionError, OSError):
            ended = "connection lost"
        except asyncio.CancelledError:
            ended = "server stopping"
        finally:
            self.stats.requests += requests
            self.stats.errors += errors
            self._open.discard(writer)
            self._tasks.discard(task)
            await _close(writer)
            self.log(f"client {name}: {requests} requests, {errors} errors, "
                     f"{time.monotonic() - started:.1f} s, {ended}")

    async def run(self, host, port, ready=None):
        """Serve until SIGTERM or SIGINT; ``ready(host, port)`` is called once listening."""
        loop = asyncio.get_running_loop()
        stop = asyncio.Event()
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, stop.set)
        server = await asyncio.start_server(self.handle, host, port, limit=READ_CHUNK)
        bound = server.sockets[0].getsockname()
        if ready is not None:
            ready(bound[0], bound[1])
        async with server:
            await stop.wait()
            server.close()
            tasks = list(self._tasks)
            for task in tasks:
                task.cancel()
            if tasks:
                await asyncio.wait(tasks, timeout=5.0)
        self.log(f"robocal serve: stopped; {self.stats.summary()}")


if hasattr(asyncio, "timeout"):  # Python 3.11: a deadline on the running task, no new task
    async def _read(reader):
        """The next bytes from a client (b"" at its end); TimeoutError after IDLE_TIMEOUT s."""
        async with asyncio.timeout(IDLE_TIMEOUT):
            return await reader.read(READ_CHUNK)
else:  # pragma: no cover - Python 3.10
    async def _read(reader):
        """The next bytes from a client (b"" at its end); TimeoutError after IDLE_TIMEOUT s."""
        return await asyncio.wait_for(reader.read(READ_CHUNK), IDLE_TIMEOUT)


async def _lines(reader):
    """Request lines (bytes, without newline) as they arrive; None for a line longer than
    MAX_LINE (its bytes discarded as they come, never held); a last line without newline at
    the end of the stream counts as a line.  Stops after IDLE_TIMEOUT s without a byte."""
    buffer = bytearray()
    discarding = False
    while True:
        chunk = await _read(reader)
        if not chunk:
            if buffer and not discarding:
                yield bytes(buffer)
            elif discarding:
                yield None
            return
        start = 0
        while True:
            newline = chunk.find(b"\n", start)
            if newline < 0:
                if not discarding:
                    buffer += chunk[start:]
                    if len(buffer) > MAX_LINE:
                        buffer.clear()
                        discarding = True
                break
            if discarding:
                discarding = False
                yield None
            else:
                buffer += chunk[start:newline]
                line = bytes(buffer)
                buffer.clear()
                yield None if len(line) > MAX_LINE else line.rstrip(b"\r")
            start = newline + 1


async def _close(writer):
    try:
        writer.close()
        await asyncio.wait_for(writer.wait_closed(), 2.0)
    except (ConnectionError, OSError, asyncio.TimeoutError):
        pass


def serve(model_path, host="127.0.0.1", port=8765, fmt="json", ready=None):
    """Load the model and serve it until SIGTERM / SIGINT (see the module docstring)."""
    answerer = Answerer(model_path, fmt)
    warm_up(answerer)
    server = Server(answerer)

    def announce(bound_host, bound_port):
        print(f"robocal serve: {model_path} ({answerer.model.method}) on {bound_host}:{bound_port}, "
              f"{fmt} lines", flush=True)
        if ready is not None:
            ready(bound_host, bound_port)

    asyncio.run(server.run(host, port, announce))
    return server.stats


def warm_up(answerer):
    """Answer one target the model reaches (a training-like pose of the nominal robot), so
    that the first client does not pay for building the one-target machinery."""
    robot = answerer.robot
    q = np.clip(np.zeros(robot.n_joints), robot.lower, robot.upper)
    pose = answerer.compensator.chain.fk(robot.joints_from_file(robot.joints_to_file(q[None])))[0]
    xyz, rpy = pose_to_xyz_rpy(pose[None])
    line = json.dumps(dict(zip(CARTESIAN, xyz[0].tolist() + np.degrees(rpy[0]).tolist())))
    if answerer.fmt == "csv":
        line = ",".join(repr(v) for v in xyz[0].tolist() + np.degrees(rpy[0]).tolist())
    answerer.answer(line.encode())
    if answerer.fitted.bound_ is not None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            # The bound outside the domain (its fallback's, the training configurations'
            # search tree) is prepared on first use: here, not in a client's request.
            answerer.fitted.bound_.predict_one(q, False)
