"""Client of a running dysa-server: watch and steer a simulation from Python.

The verbs mirror the ``dysa`` command line and the gRPC service dysa.v1.Simulation
(proto/dysa/v1/simulation.proto)::

    from dysa.client import Client

    with Client("127.0.0.1:50051") as sim:
        sim.pause()
        print(sim.params()["viscosity"].value)      # m^3/s
        sim.set(viscosity=0.005)
        sim.step(10)                                # 10 frames, then paused
        for frame in sim.frames(fields=("positions", "velocity"), limit=5):
            print(frame.sim_frame, frame.time, frame.positions.shape)

Units are SI (metres, seconds, kilograms) unless a field says otherwise. Every call returns
plain Python values (the dataclasses below, numpy arrays for frames); failures raise DysaError.

Needs Debian's python3-grpcio, python3-protobuf, python3-numpy and python3-zstandard (run with
/usr/bin/python3) and the stubs the build generates (see the dysa package docstring).
"""

from __future__ import annotations

import bisect
import json
import os
import random
import threading
import time
from dataclasses import dataclass
from typing import Any, Dict, Iterable, List, Mapping, Optional, Tuple, Union

try:
    import grpc
except ImportError as _error:  # pragma: no cover - depends on the machine
    raise ImportError(
        "dysa.client needs the grpc module (Debian package python3-grpcio); run it with "
        "/usr/bin/python3: %s" % _error) from _error

import dysa as _dysa

try:
    from dysa.v1 import simulation_pb2 as _pb
    from dysa.v1 import simulation_pb2_grpc as _pb_grpc
except ImportError as _error:
    raise ImportError(
        "dysa.client cannot import the generated gRPC stubs dysa.v1 (%s). They are generated "
        "by the build: run scripts/build.sh (it writes build/release/python/dysa/v1), or, for a "
        "build outside this checkout, set DYSA_PYTHON_STUBS to its python directory, which "
        "contains dysa/v1/simulation_pb2.py. Searched: %s"
        % (_error, ", ".join(_dysa.STUB_SEARCH_PATH))) from _error

from dysa.codec import Frame, FrameDecoder
from dysa.refinement import merge_refinement

__all__ = [
    "Client",
    "ControlResult",
    "DysaError",
    "FIELDS",
    "FrameStream",
    "Motion",
    "MotionKey",
    "ParamInfo",
    "PassTiming",
    "Box",
    "Scene",
    "SceneInfo",
    "Sphere",
    "Status",
]

# Field names accepted by Client.frames(), with their aliases (the codec's Frame attributes).
FIELDS: Dict[str, int] = {
    "positions": _pb.FIELD_POSITIONS,
    "speed": _pb.FIELD_SPEED,
    "velocity": _pb.FIELD_VELOCITY,
    "velocities": _pb.FIELD_VELOCITY,
    "density": _pb.FIELD_DENSITY,
    "densities": _pb.FIELD_DENSITY,
}

_STATES = {
    _pb.RUN_STATE_RUNNING: "running",
    _pb.RUN_STATE_PAUSED: "paused",
}

# Frame messages stay under gRPC's 4 MiB default (the server chunks frames); a larger limit on
# this side costs nothing and keeps a future server with bigger messages working.
_MAX_RECEIVE_BYTES = 64 * 1024 * 1024


class DysaError(RuntimeError):
    """A call failed.

    Attributes:
        code: the gRPC status (grpc.StatusCode), e.g. INVALID_ARGUMENT for a parameter out of
            range, UNAVAILABLE when the server cannot be reached, UNAUTHENTICATED for a missing
            or wrong token.
        details: the server's message (for INVALID_ARGUMENT it names the field and its range),
            or gRPC's own for connection failures.
    """

    def __init__(self, message: str, code: Optional[grpc.StatusCode] = None,
                 details: str = "") -> None:
        super().__init__(message)
        self.code = code
        self.details = details


@dataclass(frozen=True)
class PassTiming:
    """Wall time of one pass of the solver step."""

    name: str
    last_ms: float  # milliseconds, the latest step
    mean_ms: float  # milliseconds, mean over the steps since the scene was loaded
    calls: int  # steps timed


@dataclass(frozen=True)
class StreamStatus:
    """One open frame stream as the server measures it (docs/server.md, "Budgets and detail")."""

    detail: float  # fraction of the particles (after the stride) it is sent, (0, 1]
    particles: int  # particles in its latest delivered frame
    bytes_per_second: float  # delivered per wall second (~1 s average)
    frames_per_second: float  # delivered per wall second (~1 s average)
    age_s: float  # s, age of the data of its latest delivered frame; 0: none yet
    link_bytes_per_second: float  # what the link took while sending; 0: not measured yet
    fps_target: float  # its budget as requested; 0: none
    byte_budget: int  # bytes per second; 0: none
    particle_budget: int  # particles per frame; 0: none
    stream_id: int = 0  # FrameStream.stream_id of the call
    view: bool = False  # it has a camera (set_stream_view): view-dependent detail


@dataclass(frozen=True)
class Status:
    """State of the server and its simulation (Client.status())."""

    state: str  # "running", "paused" or "unspecified"
    step: int  # solver steps since the last reset
    frame: int  # frames since the last reset
    time: float  # s, simulated time since the last reset
    particles: int  # particle count
    solver: str  # registered solver name, e.g. "seed"
    scene: str  # the running scene's name
    frames_per_second: float  # frames simulated per wall second, recent average
    target_frame_rate: float  # frames per wall second the server aims for; 0: unlimited
    passes: Tuple[PassTiming, ...]  # per-pass timings, in pass order
    subscribers: int  # open frame streams
    alarm: str  # empty when healthy, else why the simulation paused itself
    warning: str  # empty unless the latest frame's steps had to limit the solver's accuracy
    history_frames: int  # frames available to step back right now
    history_bytes: int  # bytes of memory the history holds
    frames_encoded: int  # frames encoded for subscribers since the server started
    scene_version: int = 0  # changes whenever get_scene() would answer differently
    solver_threads: int = 0  # OpenMP threads the solver steps with (dysa-server --threads)
    # Where the simulation steps (dysa-server --device): "cpu", or the GPU, e.g.
    # "cuda:0 NVIDIA H200, 139.8 GiB, sm_90"; empty from a server that predates it.
    device: str = ""
    device_memory_bytes: int = 0  # bytes of GPU memory the simulation holds; 0 on the CPU
    # While paused: a hash of every particle's id, position and velocity (the state is then a
    # frame, and stepping N frames and back N gives the same hash); 0 while running.
    state_hash: int = 0
    streams: Tuple[StreamStatus, ...] = ()  # each open frame stream

    @property
    def paused(self) -> bool:
        """Whether the simulation is paused."""
        return self.state == "paused"

    @property
    def running(self) -> bool:
        """Whether the simulation is running."""
        return self.state == "running"


@dataclass(frozen=True)
class ControlResult:
    """What a control (pause, resume, step, back, reset, load) did."""

    status: Status  # after the control was applied
    reset: bool  # the simulation was re-spawned
    frames_moved: int  # step/back: frames actually moved (back stops at the oldest kept)


@dataclass(frozen=True)
class ParamInfo:
    """A simulation parameter (Client.params()), every number in `unit`."""

    name: str  # e.g. "viscosity"
    value: float
    unit: str  # e.g. "m^3/s"; empty for dimensionless
    min: float  # inclusive
    max: float  # inclusive
    default: float
    integer: bool  # only whole numbers are accepted
    needs_reset: bool  # changing it re-spawns the fluid
    description: str
    # The solvers that read it (names as in Scene.solvers); the others ignore it. Empty from a
    # server older than this field.
    solvers: Tuple[str, ...] = ()

    def read_by(self, solver: str) -> bool:
        """Whether `solver` reads this parameter (True when either is unknown)."""
        return not solver or not self.solvers or solver in self.solvers


@dataclass(frozen=True)
class SceneInfo:
    """A built-in scene (Client.scenes())."""

    name: str
    description: str
    particles: int  # particle count with the scene's own parameters
    solver: str


Vec3 = Tuple[float, float, float]


@dataclass(frozen=True)
class MotionKey:
    """One keyframe of an obstacle's motion."""

    time: float  # s, simulated time (Status.time, Frame.time)
    displacement: Vec3  # m, from the obstacle's given position


@dataclass(frozen=True)
class Motion:
    """An obstacle's prescribed translation (scenes/README.md, "Motion").

    The displacement is linear in time between keys; before the first key it is the first
    key's, after the last key the last's. No keys: the obstacle does not move.
    """

    keys: Tuple[MotionKey, ...] = ()  # times strictly increasing

    @property
    def moving(self) -> bool:
        return bool(self.keys)

    def displacement_at(self, time: float) -> Vec3:
        """The displacement (m) at simulated time `time` (s), as the server's solver has it."""
        if not self.keys:
            return (0.0, 0.0, 0.0)
        later = bisect.bisect_right([k.time for k in self.keys], time)
        if later == 0:
            return self.keys[0].displacement
        if later == len(self.keys):
            return self.keys[-1].displacement
        a, b = self.keys[later - 1], self.keys[later]
        s = (time - a.time) / (b.time - a.time)
        return tuple(da + s * (db - da)  # type: ignore[return-value]
                     for da, db in zip(a.displacement, b.displacement))


@dataclass(frozen=True)
class Sphere:
    """A sphere obstacle, static unless its motion has keys."""

    center: Vec3  # m, with no displacement
    radius: float  # m
    motion: Motion = Motion()


@dataclass(frozen=True)
class Box:
    """An axis-aligned box obstacle, static unless its motion has keys."""

    min: Vec3  # m, the corner of smallest coordinates, with no displacement
    max: Vec3  # m, the corner of largest coordinates, with no displacement
    motion: Motion = Motion()


@dataclass(frozen=True)
class Scene:
    """The running scene's geometry and the registered solvers (Client.get_scene())."""

    name: str
    description: str
    solver: str  # the running solver
    solvers: Tuple[str, ...]  # every registered solver name (load(..., solver=...))
    domain_min: Vec3  # m, the walls' corner of smallest coordinates
    domain_max: Vec3  # m, the walls' corner of largest coordinates
    spheres: Tuple[Sphere, ...]
    boxes: Tuple[Box, ...]
    particle_radius: float  # m, half the smallest rest spacing of the spawned particles
    scene_version: int  # as Status.scene_version when this was taken


def _vec3(m: Any) -> Vec3:
    return (m.x, m.y, m.z)


def _motion(m: Any) -> Motion:
    return Motion(tuple(MotionKey(k.time, _vec3(k.displacement)) for k in m.keys))


def _scene(m: Any) -> Scene:
    return Scene(
        name=m.name, description=m.description, solver=m.solver, solvers=tuple(m.solvers),
        domain_min=_vec3(m.domain_min), domain_max=_vec3(m.domain_max),
        spheres=tuple(Sphere(_vec3(s.center), s.radius, _motion(s.motion)) for s in m.spheres),
        boxes=tuple(Box(_vec3(b.min), _vec3(b.max), _motion(b.motion)) for b in m.boxes),
        particle_radius=m.particle_radius, scene_version=m.scene_version)


def _status(m: Any) -> Status:
    return Status(
        state=_STATES.get(m.state, "unspecified"), step=m.step, frame=m.frame, time=m.time,
        particles=m.particles, solver=m.solver, scene=m.scene,
        frames_per_second=m.frames_per_second, target_frame_rate=m.target_frame_rate,
        passes=tuple(PassTiming(p.name, p.last_ms, p.mean_ms, p.calls) for p in m.passes),
        subscribers=m.subscribers, alarm=m.alarm, warning=m.warning, history_frames=m.history_frames,
        history_bytes=m.history_bytes, frames_encoded=m.frames_encoded,
        scene_version=m.scene_version, solver_threads=m.solver_threads, device=m.device,
        device_memory_bytes=m.device_memory_bytes, state_hash=m.state_hash,
        streams=tuple(StreamStatus(s.detail, s.particles, s.bytes_per_second,
                                   s.frames_per_second, s.age_s, s.link_bytes_per_second,
                                   s.fps_target, s.byte_budget, s.particle_budget,
                                   s.stream_id, s.view)
                      for s in m.streams))


def _control(m: Any) -> ControlResult:
    return ControlResult(status=_status(m.status), reset=m.reset, frames_moved=m.frames_moved)


def _params(messages: Iterable[Any]) -> Dict[str, ParamInfo]:
    return {p.name: ParamInfo(p.name, p.value, p.unit, p.min, p.max, p.default_value,
                              p.integer, p.needs_reset, p.description, tuple(p.solvers))
            for p in messages}


def _count(n: int, verb: str) -> int:
    """Checks a frame count for step/back (the wire type is uint32; 0 would mean 1)."""
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 0xFFFFFFFF:
        raise ValueError("%s: the frame count must be an integer in [1, 2^32 - 1], not %r"
                         % (verb, n))
    return n


class Client:
    """A connection to a dysa-server.

    Args:
        address: "HOST:PORT" of the server (dysa-server --listen).
        token: sent as "authorization: Bearer TOKEN" with every call, for a server started with
            --token-file.
        tls_ca: for a server started with --tls-cert/--tls-key: the PEM file (path) or PEM bytes
            of the certificate authority (or the self-signed certificate) to trust. None: plain
            TCP.
        timeout: seconds each call (not a frame stream) may take before it fails with
            DEADLINE_EXCEEDED. Also the attribute `timeout`; None waits without limit.
        tls_server_name: the name the server's certificate must carry, when it differs from the
            host part of `address` (e.g. a certificate for "localhost" reached at 127.0.0.1).

    Connecting is lazy: the first call connects, and fails with DysaError (UNAVAILABLE) naming
    the address when no server answers there. Use it as a context manager, or call close().
    """

    def __init__(self, address: str = "127.0.0.1:50051", token: Optional[str] = None,
                 tls_ca: Union[str, bytes, os.PathLike, None] = None,
                 timeout: Optional[float] = 30.0,
                 tls_server_name: Optional[str] = None) -> None:
        self.address = address
        self.timeout = timeout
        self._metadata: Tuple[Tuple[str, str], ...] = ()
        if token is not None:
            token = token.strip()  # token files usually end with a newline
            if not token:
                raise ValueError("token is empty")
            self._metadata = (("authorization", "Bearer " + token),)
        options: List[Tuple[str, Any]] = [("grpc.max_receive_message_length",
                                           _MAX_RECEIVE_BYTES)]
        if tls_ca is None:
            self._channel = grpc.insecure_channel(address, options=options)
        else:
            if isinstance(tls_ca, bytes):
                root = tls_ca
            else:
                with open(tls_ca, "rb") as f:
                    root = f.read()
            if tls_server_name:
                options.append(("grpc.ssl_target_name_override", tls_server_name))
            credentials = grpc.ssl_channel_credentials(root_certificates=root)
            self._channel = grpc.secure_channel(address, credentials, options=options)
        self._stub = _pb_grpc.SimulationStub(self._channel)
        self._closed = False

    # --- lifetime -------------------------------------------------------------------------

    def close(self) -> None:
        """Closes the connection; open frame streams end (their iteration stops)."""
        if not self._closed:
            self._closed = True
            self._channel.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        return "Client(%r)" % self.address

    def wait_ready(self, timeout: float = 10.0) -> None:
        """Waits until the connection to the server is up (at most `timeout` seconds).

        Calls do not need it (they connect by themselves); it is for waiting on a server that
        is starting. Raises DysaError (UNAVAILABLE) when it is not up in time.
        """
        try:
            grpc.channel_ready_future(self._channel).result(timeout=timeout)
        except grpc.FutureTimeoutError:
            raise DysaError("no DySAQUASIMs server answered at %s within %g s"
                            % (self.address, timeout), grpc.StatusCode.UNAVAILABLE) from None

    # --- calls ----------------------------------------------------------------------------

    def _error(self, error: grpc.RpcError, rpc: str) -> DysaError:
        """A DysaError with a message that says what to do for the common failures."""
        code = error.code() if hasattr(error, "code") else grpc.StatusCode.UNKNOWN
        details = (error.details() if hasattr(error, "details") else str(error)) or ""
        if code == grpc.StatusCode.UNAVAILABLE:
            message = ("the DySAQUASIMs server at %s is unavailable (not running, not "
                       "listening there, or shutting down): %s" % (self.address, details))
        elif code == grpc.StatusCode.DEADLINE_EXCEEDED:
            message = ("%s: no reply from the server at %s within %s s (Client timeout)"
                       % (rpc, self.address, self.timeout))
        elif code == grpc.StatusCode.UNAUTHENTICATED:
            message = ("%s: the server at %s refused the call (UNAUTHENTICATED): %s; pass its "
                       "token (Client(token=...))" % (rpc, self.address, details))
        else:
            message = "%s: %s: %s" % (rpc, code.name if code else "UNKNOWN", details)
        return DysaError(message, code, details)

    def _call(self, rpc: str, request: Any) -> Any:
        """Calls unary method `rpc` with the token and the timeout."""
        if self._closed:
            raise DysaError("%s: the client is closed" % rpc, grpc.StatusCode.CANCELLED)
        try:
            return getattr(self._stub, rpc)(request, timeout=self.timeout,
                                            metadata=self._metadata)
        except grpc.RpcError as error:
            raise self._error(error, rpc) from None

    def status(self) -> Status:
        """The simulation's state, time, counters and per-pass timings (never waits for a
        step)."""
        return _status(self._call("GetStatus", _pb.GetStatusRequest()))

    def pause(self) -> ControlResult:
        """Pauses the simulation (between two solver steps, possibly inside a frame)."""
        return _control(self._call("Pause", _pb.PauseRequest()))

    def resume(self) -> ControlResult:
        """Resumes the simulation; it runs at the server's frame rate."""
        return _control(self._call("Resume", _pb.ResumeRequest()))

    def step(self, n: int = 1) -> ControlResult:
        """Advances n frames (each iterations_per_frame solver steps), then pauses.

        Returns once the frames have been simulated, or earlier when another control arrives
        or Client.timeout is about to expire: frames_moved says how many were.
        """
        return _control(self._call("Step", _pb.StepRequest(count=_count(n, "step"))))

    def back(self, n: int = 1) -> ControlResult:
        """Returns to the state n frames earlier, then pauses. Stops at the oldest frame the
        history keeps: frames_moved says how far it went."""
        return _control(self._call("StepBack", _pb.StepBackRequest(count=_count(n, "back"))))

    def reset(self) -> ControlResult:
        """Re-spawns the fluid of the current scene with the current parameters; time goes
        to 0. The run state (running or paused) is the server's choice; see the status."""
        return _control(self._call("Reset", _pb.ResetRequest()))

    def params(self) -> Dict[str, ParamInfo]:
        """Every parameter by name, in declaration order, with its value, unit and range."""
        return _params(self._call("GetParams", _pb.GetParamsRequest()).params)

    def set(self, **values: float) -> bool:
        """Changes parameters by name, e.g. ``set(viscosity=0.005, gravity=-9.81)``; values in
        each parameter's unit (see params()).

        All or nothing: an unknown name or a value out of range raises DysaError
        (INVALID_ARGUMENT, naming the field and its range) and nothing is applied. Returns
        whether a changed parameter needed a reset (the fluid was re-spawned).
        """
        return self.set_params(values)

    def set_params(self, values: Mapping[str, float]) -> bool:
        """set() with a mapping of name -> value; returns whether the fluid was re-spawned."""
        request = _pb.UpdateParamsRequest()
        for name, value in values.items():
            # bool is an int in Python; True as a viscosity is surely a mistake.
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise TypeError("set: %s must be a number, not %r" % (name, value))
            request.params.values[name] = float(value)
            # Only the named entries are applied (the server's update_mask contract), so a
            # future field of ParamValues is never reset by accident.
            request.update_mask.paths.append("values." + name)
        return self._call("UpdateParams", request).reset

    def load(self, scene: Union[str, os.PathLike, Mapping[str, Any]],
             solver: Optional[str] = None) -> ControlResult:
        """Replaces the running scene.

        `scene` is one of:
        - a mapping: the scene itself (scenes/README.md), sent as JSON;
        - a str that starts with "{": JSON scene text;
        - an os.PathLike, or a str that names an existing file, ends with ".json" or contains
          a path separator: a scene file on this machine (its content is sent, so the server
          need not see the file);
        - any other str: a built-in scene name (see scenes()).

        `solver`: a registered solver name (get_scene().solvers) to run the scene with instead of
        its own; None or "": the scene's own. An unknown name raises DysaError
        (INVALID_ARGUMENT, naming `solver` and the registered names).

        A scene that does not parse or validate raises DysaError (INVALID_ARGUMENT, naming the
        field) and the old scene keeps running. A missing file raises FileNotFoundError.
        """
        request = _pb.LoadSceneRequest()
        if isinstance(scene, Mapping):
            request.json_text = json.dumps(scene)
        elif isinstance(scene, os.PathLike) or (
                isinstance(scene, str) and not scene.lstrip().startswith("{") and (
                    os.path.isfile(scene) or scene.endswith(".json") or os.sep in scene
                    or "/" in scene)):
            with open(scene, encoding="utf-8") as f:
                request.json_text = f.read()
        elif isinstance(scene, str):
            if scene.lstrip().startswith("{"):
                request.json_text = scene
            else:
                request.name = scene
        else:
            raise TypeError("load: scene must be a name, a path, JSON text or a mapping, not %r"
                            % type(scene).__name__)
        if solver is not None:
            if not isinstance(solver, str):
                raise TypeError("load: solver must be a str, not %r" % type(solver).__name__)
            request.solver = solver
        return _control(self._call("LoadScene", request))

    def load_scene(self, scene: Union[str, os.PathLike, Mapping[str, Any]],
                   solver: Optional[str] = None) -> ControlResult:
        """The same as load()."""
        return self.load(scene, solver)

    def scenes(self) -> List[SceneInfo]:
        """The built-in scenes (the running one is status().scene)."""
        reply = self._call("ListScenes", _pb.ListScenesRequest())
        return [SceneInfo(s.name, s.description, s.particles, s.solver) for s in reply.scenes]

    def get_scene(self) -> Scene:
        """The running scene: solver and the registered ones, domain, obstacles and the
        particle radius (never waits for a step). Ask again when status().scene_version
        changes."""
        return _scene(self._call("GetScene", _pb.GetSceneRequest()))

    def set_stream_view(self, stream_id: int, eye: Vec3, target: Vec3,
                        up: Vec3 = (0.0, 1.0, 0.0), fov_y_deg: float = 45.0,
                        aspect: float = 1.0) -> None:
        """Gives an open frame stream (FrameStream.stream_id) a camera (docs/server.md,
        "View-dependent detail"): with a budget, the particles in view go first, densest near
        the camera; while paused, refinements complete the frame (FrameStream assembles them).

        eye, target: m; up: any length, not parallel to target - eye; fov_y_deg: vertical
        field of view, [1, 179] degrees; aspect: width / height, [0.05, 20]. A bad value raises
        DysaError (INVALID_ARGUMENT) naming the field and its range.
        """
        self._call("SetStreamView", _view_request(stream_id, eye, target, up, fov_y_deg, aspect))

    def frames(self, fields: Iterable[str] = ("positions", "speed"), max_fps: float = 0.0,
               stride: int = 1, position_bits: int = 16, limit: Optional[int] = None, *,
               speed_bits: int = 0, velocity_bits: int = 0, density_bits: int = 0,
               keyframe_interval: int = 0,
               velocity_encoding: str = "components", fps_target: float = 0.0,
               byte_budget: int = 0, particle_budget: int = 0) -> "FrameStream":
        """Streams particle frames, decoded into numpy arrays (dysa.codec.Frame).

        Args:
            fields: any of "positions" (always sent), "speed" (m/s), "velocity" (m/s, 3
                components) and "density" (kg/m^3).
            max_fps: at most this many frames per wall second; 0: every frame simulated.
            stride: level of detail: only particles with id % stride == 0.
            position_bits: quantisation bits per axis, 1..24 (the error bound of each frame is
                in Frame.position_error, m).
            limit: stop after this many frames; None: until closed or the server ends the
                stream.
            speed_bits, velocity_bits, density_bits: 1..16; 0: the server's default (8, 12,
                16).
            keyframe_interval: frames between keyframes; 0: the server's default (60).
            velocity_encoding: with "velocity": "components" (vx, vy, vz, the tightest bound
                per component) or "octahedral" (|v| and an octahedral direction: the error is
                relative to the speed); Frame.velocity_error is the bound either way.
            fps_target, byte_budget, particle_budget: budgets (docs/server.md, "Budgets and
                detail"): frames per second to hold on this link, (0, 1000]; bytes per second
                at most, >= 1000 (needs fps_target); particles per frame at most,
                1..20,000,000; 0: none. With any of them the server sends the largest stable,
                nested, spatially even subset of the particles that fits; each Frame then has
                detail_fraction < 1 and `ids` naming its particles (always set). With a
                camera (FrameStream.set_view) the subset follows the view, and while paused
                the stream yields the shown frame again, more complete each time, until
                `partial` is False (the full frame, bit-exact).

        Returns a FrameStream: iterate it for Frames. The stream starts with the current
        frame (a keyframe), even when paused, then brings each frame as it is simulated,
        newest first: a reader that falls behind skips frames (it never slows the simulation).
        Each Frame also carries `sim_frame` (frame number since the last reset),
        `frames_skipped` (frames this stream missed just before it) and `produced_unix_us`
        (server wall clock, microseconds since the Unix epoch). Close it (or leave a with
        block, or close the generator-like iterator) to end the call on the server.
        """
        if isinstance(fields, str):  # frames(fields="velocity"): one name, not its letters
            fields = (fields,)
        codes = []
        for name in fields:
            if name not in FIELDS:
                raise ValueError("frames: unknown field %r; known: %s"
                                 % (name, ", ".join(FIELDS)))
            if FIELDS[name] not in codes:
                codes.append(FIELDS[name])
        if limit is not None and limit < 1:
            raise ValueError("frames: limit must be >= 1 or None, not %r" % (limit,))
        encodings = {"components": _pb.VELOCITY_ENCODING_COMPONENTS,
                     "octahedral": _pb.VELOCITY_ENCODING_OCTAHEDRAL}
        if velocity_encoding not in encodings:
            raise ValueError("frames: velocity_encoding must be one of %s, not %r"
                             % (", ".join(encodings), velocity_encoding))
        _check_budgets(fps_target, byte_budget, particle_budget)
        request = _pb.StreamFramesRequest(
            fields=codes, max_fps=max_fps, position_bits=position_bits, speed_bits=speed_bits,
            velocity_bits=velocity_bits, density_bits=density_bits, stride=stride,
            keyframe_interval=keyframe_interval,
            velocity_encoding=encodings[velocity_encoding], fps_target=fps_target,
            byte_budget=byte_budget, particle_budget=particle_budget)
        # With a budget the stream reports each frame it receives (AckFrames): the server then
        # measures what the link delivers, not what its transport took (docs/server.md).
        if fps_target or byte_budget or particle_budget:
            request.ack_token = random.SystemRandom().randrange(1, 2**64)
        if self._closed:
            raise DysaError("StreamFrames: the client is closed", grpc.StatusCode.CANCELLED)
        # No deadline: a stream lasts as long as the reader wants it.
        call = self._stub.StreamFrames(request, metadata=self._metadata)
        return FrameStream(self, call, limit, request.ack_token)


def _view_request(stream_id: int, eye: Vec3, target: Vec3, up: Vec3, fov_y_deg: float,
                  aspect: float) -> Any:
    """A SetStreamViewRequest (the server checks the ranges and names a bad field)."""
    def vec(name: str, v: Any) -> Any:
        try:
            x, y, z = (float(c) for c in v)
        except (TypeError, ValueError):
            raise ValueError("set_stream_view: %s must be 3 numbers (m), not %r"
                             % (name, v)) from None
        return _pb.Vec3(x=x, y=y, z=z)

    return _pb.SetStreamViewRequest(stream_id=int(stream_id), eye=vec("eye", eye),
                                    target=vec("target", target), up=vec("up", up),
                                    fov_y_deg=float(fov_y_deg), aspect=float(aspect))


def _check_budgets(fps_target: float, byte_budget: int, particle_budget: int) -> None:
    """Raises ValueError naming the argument and its range (the server checks them too)."""
    if not (isinstance(fps_target, (int, float)) and 0 <= fps_target <= 1000):
        raise ValueError("frames: fps_target must be in (0, 1000] frames per second, or 0 for "
                         "none, not %r" % (fps_target,))
    if not (isinstance(byte_budget, int) and (byte_budget == 0 or 1000 <= byte_budget < 2**63)):
        raise ValueError("frames: byte_budget must be >= 1000 bytes per second, or 0 for none, "
                         "not %r" % (byte_budget,))
    if byte_budget and not fps_target:
        raise ValueError("frames: byte_budget needs fps_target (bytes per second are spread over "
                         "the target frame rate)")
    if not (isinstance(particle_budget, int) and 0 <= particle_budget <= 20_000_000):
        raise ValueError("frames: particle_budget must be in [1, 20000000] particles per frame, "
                         "or 0 for none, not %r" % (particle_budget,))


class FrameStream:
    """An open StreamFrames call: an iterator of decoded dysa.codec.Frame objects.

    Behaves like a generator: close() ends the call on the server (also from another thread,
    where it makes a blocked iteration stop), and so do leaving a with block, reaching `limit`
    and garbage collection. Iteration stops quietly after close() or Client.close(); a server
    that shuts down or fails the stream raises DysaError.

    Counters: frames_received, frames_skipped (sum of what the server reported),
    bytes_received (chunk bytes). stream_id: the call's id on the server (set_view), once the
    first frame arrived.

    Each Frame carries `partial` (a view stream's frame that still lacks particles) and
    `refined` (this frame is the one before plus a refinement's particles).
    """

    def __init__(self, client: Client, call: Any, limit: Optional[int],
                 ack_token: int = 0) -> None:
        self._client = client
        # Frames received completely, and the count last reported (one report in flight at
        # most; counts that come meanwhile collapse into the newest).
        self._ack_token = ack_token
        self._arrived = 0
        self._reported = 0
        self._ack_in_flight = False
        self._ack_rtt_us = 0  # the latest report's round trip, sent with the next
        self._call = call
        self._limit = limit
        self._decoder = FrameDecoder()
        self._closed = False
        self._lock = threading.RLock()  # re-entered by an AckFrames callback run at once
        self.frames_received = 0
        self.frames_skipped = 0
        self.bytes_received = 0
        self.stream_id = 0
        self._shown: Optional[Frame] = None  # a partial frame that refinements add to
        self._shown_sim_frame = -1

    def __iter__(self) -> "FrameStream":
        return self

    def __next__(self) -> Frame:
        while True:
            if self._closed:
                raise StopIteration
            try:
                message = next(self._call)
            except StopIteration:
                self.close()
                raise
            except grpc.RpcError as error:
                ended_by_us = self._closed or self._client._closed
                self.close()
                if ended_by_us and error.code() == grpc.StatusCode.CANCELLED:
                    raise StopIteration from None
                raise self._client._error(error, "StreamFrames") from None
            self.frames_skipped += message.frames_skipped
            self.bytes_received += sum(len(c) for c in message.chunks)
            if message.stream_id:
                self.stream_id = message.stream_id
            if message.last_of_frame and self._ack_token:
                with self._lock:
                    self._arrived += 1
                    if not self._ack_in_flight:
                        self._send_ack_locked()
            try:
                frame = self._decoder.add_chunks(message.chunks)
            except Exception:
                self.close()
                raise
            if frame is None:
                # More messages of this frame to come, or a delta frame the decoder cannot use
                # (it waits for the next keyframe).
                continue
            frame.refined = False
            if message.refines:
                if self._shown is None or self._shown_sim_frame != message.frame:
                    continue  # refines a frame this stream does not show
                frame = merge_refinement(self._shown, frame)
                frame.refined = True
                if not message.partial:
                    frame.detail_threshold = 0  # every particle: full detail
            frame.partial = message.partial
            self._shown = frame if message.partial else None
            self._shown_sim_frame = message.frame
            frame.sim_frame = message.frame
            frame.frames_skipped = message.frames_skipped
            frame.produced_unix_us = message.produced_unix_us
            self.frames_received += 1
            if self._limit is not None and self.frames_received >= self._limit:
                self.close()
            return frame

    def set_view(self, eye: Vec3, target: Vec3, up: Vec3 = (0.0, 1.0, 0.0),
                 fov_y_deg: float = 45.0, aspect: float = 1.0) -> None:
        """This stream's camera (Client.set_stream_view); call after the first frame."""
        if not self.stream_id:
            raise DysaError("set_view: no frame received yet (the stream's id comes with it)",
                            grpc.StatusCode.FAILED_PRECONDITION)
        self._client.set_stream_view(self.stream_id, eye, target, up, fov_y_deg, aspect)

    def _send_ack_locked(self) -> None:
        """Reports the frames received so far, asynchronously (self._lock held)."""
        self._ack_in_flight = True
        self._reported = self._arrived
        request = _pb.AckFramesRequest(ack_token=self._ack_token, frames=self._reported,
                                       rtt_us=self._ack_rtt_us)
        sent_at = time.monotonic()
        future = self._client._stub.AckFrames.future(request, timeout=5,
                                                    metadata=self._client._metadata)

        def done(f: Any) -> None:
            with self._lock:
                self._ack_in_flight = False
                code = f.code()
                if code == grpc.StatusCode.OK:
                    self._ack_rtt_us = max(1, min(2**32 - 1,
                                                  int((time.monotonic() - sent_at) * 1e6)))
                # An older server has no AckFrames; an ended stream has no token: stop.
                if code in (grpc.StatusCode.UNIMPLEMENTED, grpc.StatusCode.NOT_FOUND):
                    self._ack_token = 0
                elif not self._closed and self._arrived > self._reported:
                    self._send_ack_locked()

        future.add_done_callback(done)

    def close(self) -> None:
        """Ends the stream (cancels the call; idempotent, thread-safe)."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self._call.cancel()

    @property
    def closed(self) -> bool:
        """Whether the stream has ended."""
        return self._closed

    def __enter__(self) -> "FrameStream":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __del__(self) -> None:
        # Like a generator's finalisation: an abandoned stream does not stay open on the server.
        try:
            self.close()
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass
