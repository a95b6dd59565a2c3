"""End-to-end tests of the Python client (clients/python/dysa/client.py) against the real server.

Each test class starts its own dysa-server on a free port (--listen 127.0.0.1:0 --port-file F),
talks to it only through dysa.client, and stops it with SIGTERM, which must exit with status 0.
The example scripts (clients/python/examples) run as subprocesses against the same server.

Run: /usr/bin/python3 tests/python/test_client.py [unittest args], with
  DYSA_SERVER_BINARY  the dysa-server executable (default: build/release/server/dysa-server)
  DYSA_PYTHON_STUBS   the build's python directory, which holds dysa/v1 (see dysa/__init__.py)
CTest sets both (tests/CMakeLists.txt).
"""

import csv
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import unittest
from pathlib import Path
import grpc
import numpy as np

_REPO = Path(__file__).resolve().parents[2]


def _die_with_parent() -> None:
    """In the child before exec: SIGKILL when the test process ends (PR_SET_PDEATHSIG), so a
    test killed mid-run leaves no server behind."""
    import ctypes
    pr_set_pdeathsig = 1
    ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGKILL, 0, 0, 0)
_CLIENT = _REPO / "clients" / "python"
# Run by hand without PYTHONPATH: the package of this repository.
if str(_CLIENT) not in sys.path:
    sys.path.append(str(_CLIENT))

from dysa import detail  # noqa: E402
from dysa.client import Client, DysaError  # noqa: E402

_SCENE = "seed_basic"
_PARTICLES = 27000  # 30^3 (scenes/seed_basic.json)
_DOMAIN_MIN = np.array([-5.0, -3.0, -5.0])  # m
_DOMAIN_MAX = np.array([5.0, 3.0, 5.0])  # m
_START_TIMEOUT = 60.0  # s, for the server to write its port file
_STOP_TIMEOUT = 30.0  # s, for the server to exit after SIGTERM
_FRAME_TIMEOUT = 60.0  # s, for a handful of frames


def _server_binary() -> str:
    path = os.environ.get("DYSA_SERVER_BINARY")
    if path:
        return path
    return str(_REPO / "build" / "release" / "server" / "dysa-server")


def _child_env() -> dict:
    """The environment of the example scripts: this package and the stubs this test uses."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        [str(_CLIENT)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    return env


class Server:
    """A dysa-server subprocess on a free port of 127.0.0.1."""

    def __init__(self, *extra: str) -> None:
        self._dir = tempfile.TemporaryDirectory(prefix="dysa_client_test_")
        self.dir = Path(self._dir.name)
        port_file = self.dir / "port"
        self._log = open(self.dir / "server.log", "w+b")
        binary = _server_binary()
        if not os.access(binary, os.X_OK):
            raise RuntimeError("no dysa-server at %s (set DYSA_SERVER_BINARY)" % binary)
        self.process = subprocess.Popen(
            [binary, "--listen", "127.0.0.1:0", "--port-file", str(port_file),
             "--scene", _SCENE, *extra],
            stdout=self._log, stderr=subprocess.STDOUT, preexec_fn=_die_with_parent)
        # The server writes the port once it listens; poll for a complete number.
        deadline = time.monotonic() + _START_TIMEOUT
        port = ""
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError("dysa-server exited with %d before listening:\n%s"
                                   % (self.process.returncode, self.log()))
            try:
                port = port_file.read_text().strip()
            except FileNotFoundError:
                port = ""
            if port.isdigit() and int(port) > 0:
                break
            time.sleep(0.05)
        else:
            self.process.kill()
            raise RuntimeError("dysa-server wrote no port file within %g s:\n%s"
                               % (_START_TIMEOUT, self.log()))
        self.address = "127.0.0.1:" + port

    def log(self) -> str:
        """What the server printed so far."""
        self._log.flush()
        self._log.seek(0)
        return self._log.read().decode("utf-8", "replace")

    def stop(self) -> int:
        """SIGTERM, then its exit status (killed after _STOP_TIMEOUT: -9)."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(_STOP_TIMEOUT)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        return self.process.returncode

    def close(self) -> None:
        """Stops the server (if running) and removes its directory."""
        self.stop()
        self._log.close()
        self._dir.cleanup()


def _read_frames(stream, count: int, timeout: float = _FRAME_TIMEOUT,
                 keep_open: bool = False) -> list:
    """The next `count` frames of `stream`, or AssertionError after `timeout` seconds (a
    watchdog closes the stream, which stops the blocked iteration). Closes the stream after,
    unless keep_open."""
    frames = []
    watchdog = threading.Timer(timeout, stream.close)
    watchdog.start()
    try:
        for frame in stream:
            frames.append(frame)
            if len(frames) == count:
                break
    finally:
        watchdog.cancel()
        if not keep_open:
            stream.close()
    if len(frames) < count:
        raise AssertionError("got %d of %d frames within %g s" % (len(frames), count, timeout))
    return frames


def _wait_until(predicate, timeout: float = 10.0, interval: float = 0.02) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(interval)
    return predicate()


class OfflineTest(unittest.TestCase):
    """What works without a server."""

    def test_connection_failure_names_the_address(self) -> None:
        with socket.socket() as s:  # a port that was free a moment ago: nothing listens
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        address = "127.0.0.1:%d" % port
        with Client(address, timeout=10) as client:
            with self.assertRaises(DysaError) as caught:
                client.status()
            self.assertEqual(caught.exception.code, grpc.StatusCode.UNAVAILABLE)
            self.assertIn(address, str(caught.exception))
            self.assertIsInstance(caught.exception, RuntimeError)
            with self.assertRaises(DysaError) as caught:
                next(iter(client.frames()))
            self.assertEqual(caught.exception.code, grpc.StatusCode.UNAVAILABLE)

    def test_argument_checks(self) -> None:
        with Client("127.0.0.1:1") as client:
            with self.assertRaises(ValueError):
                client.frames(fields=("positions", "pressure"))
            with self.assertRaises(ValueError):
                client.step(0)
            with self.assertRaises(TypeError):
                client.set(viscosity="thick")
            with self.assertRaises(FileNotFoundError):
                client.load("no/such/scene.json")
            for kwargs, message in (
                    ({"fps_target": 5000}, "fps_target must be in \\(0, 1000\\]"),
                    ({"fps_target": -1}, "fps_target must be in"),
                    ({"fps_target": 30, "byte_budget": 10}, "byte_budget must be >= 1000"),
                    ({"byte_budget": 100000}, "byte_budget needs fps_target"),
                    ({"particle_budget": 30_000_000}, "particle_budget must be in \\[1, ")):
                with self.assertRaisesRegex(ValueError, message):
                    client.frames(**kwargs)

    def test_codec_imports_without_stubs(self) -> None:
        # A copy of the package, away from this repository's build directories, and no
        # DYSA_PYTHON_STUBS: dysa.codec imports, dysa.client says to build the project.
        with tempfile.TemporaryDirectory() as tmp:
            shutil.copytree(_CLIENT / "dysa", Path(tmp) / "dysa",
                            ignore=shutil.ignore_patterns("__pycache__"))
            env = {k: v for k, v in os.environ.items() if k != "DYSA_PYTHON_STUBS"}
            env["PYTHONPATH"] = tmp
            code = ("import dysa.codec\n"
                    "try:\n"
                    "    import dysa.client\n"
                    "except ImportError as e:\n"
                    "    print(e)\n"
                    "else:\n"
                    "    print('imported')\n")
            result = subprocess.run([sys.executable, "-c", code], cwd=tmp, env=env,
                                    capture_output=True, text=True, timeout=60)
            self.assertEqual(result.returncode, 0, result.stderr)
            self.assertIn("scripts/build.sh", result.stdout)
            self.assertIn("DYSA_PYTHON_STUBS", result.stdout)


class ClientTest(unittest.TestCase):
    """Every verb against one server running seed_basic."""

    server: Server
    client: Client

    @classmethod
    def setUpClass(cls) -> None:
        cls.server = Server("--threads", "2")
        cls.client = Client(cls.server.address, timeout=60)
        cls.client.wait_ready(30)

    @classmethod
    def tearDownClass(cls) -> None:
        cls.client.close()
        code = cls.server.stop()
        log = cls.server.log()
        cls.server.close()
        if code != 0:
            raise AssertionError("dysa-server exited with %d after SIGTERM:\n%s" % (code, log))

    def setUp(self) -> None:
        # Every test starts paused on seed_basic with its own parameters.
        self.client.pause()
        if self.client.status().scene != _SCENE:
            self.client.load(_SCENE)
            self.client.pause()

    def test_status(self) -> None:
        status = self.client.step(1).status
        self.assertTrue(status.paused)
        self.assertEqual(status.state, "paused")
        self.assertEqual(status.scene, _SCENE)
        self.assertEqual(status.solver, "seed")
        self.assertEqual(status.particles, _PARTICLES)
        self.assertEqual(status.alarm, "")
        self.assertEqual(status.solver_threads, 2)  # dysa-server --threads 2
        self.assertEqual(status.device, "cpu")  # dysa-server's default --device
        self.assertEqual(status.device_memory_bytes, 0)
        self.assertGreater(status.time, 0.0)
        names = [p.name for p in status.passes]
        self.assertIn("density", names)
        self.assertIn("integrate", names)
        for p in status.passes:
            self.assertGreaterEqual(p.last_ms, 0.0)
            self.assertGreater(p.calls, 0)
        again = self.client.status()
        self.assertEqual(again.frame, status.frame)  # paused: nothing moves

    def test_pause_step_back(self) -> None:
        start = self.client.pause().status
        per_frame = int(self.client.params()["iterations_per_frame"].value)
        stepped = self.client.step(3)
        self.assertEqual(stepped.frames_moved, 3)
        self.assertTrue(stepped.status.paused)
        self.assertEqual(stepped.status.frame, start.frame + 3)
        self.assertEqual(stepped.status.step, start.step + 3 * per_frame)
        self.assertGreater(stepped.status.time, start.time)
        self.assertEqual(self.client.status().frame, start.frame + 3)

        back = self.client.back(2)
        self.assertEqual(back.frames_moved, 2)
        self.assertTrue(back.status.paused)
        self.assertEqual(back.status.frame, start.frame + 1)
        self.assertEqual(back.status.step, start.step + per_frame)

        # Further back than the history: stops at the oldest frame kept.
        far = self.client.back(10_000)  # the server allows at most 10,000 per call
        self.assertLessEqual(far.frames_moved, start.frame + 1)
        self.assertEqual(far.status.frame, start.frame + 1 - far.frames_moved)

    def test_pause_lands_on_a_frame(self) -> None:
        """The issue's repro, as a script would write it: wherever a pause arrives, the paused
        state is a frame (a whole number of iterations_per_frame steps) whose hash stepping N
        frames forward and N back returns to."""
        per_frame = int(self.client.params()["iterations_per_frame"].value)
        for i in range(6):
            self.client.resume()
            time.sleep(0.05 * (i % 3))
            paused = self.client.pause().status
            self.assertTrue(paused.paused)
            self.assertEqual(paused.step, paused.frame * per_frame)
            self.assertEqual(self.client.status().state_hash, paused.state_hash)
            self.assertEqual(self.client.step(12).frames_moved, 12)
            back = self.client.back(12).status
            self.assertEqual((back.frame, back.step), (paused.frame, paused.step))
            self.assertEqual(back.state_hash, paused.state_hash)

    def test_resume_and_reset(self) -> None:
        start = self.client.status().frame
        self.assertTrue(self.client.resume().status.running)
        self.assertTrue(_wait_until(lambda: self.client.status().frame >= start + 2, 30))
        self.assertTrue(self.client.pause().status.paused)
        reset = self.client.reset()
        self.assertTrue(reset.reset)
        self.assertEqual(reset.status.frame, 0)
        self.assertEqual(reset.status.step, 0)
        self.assertEqual(reset.status.time, 0.0)

    def test_params(self) -> None:
        params = self.client.params()
        for name in ("time_scale", "iterations_per_frame", "gravity", "viscosity",
                     "smoothing_radius", "particle_quantity"):
            self.assertIn(name, params)
        viscosity = params["viscosity"]
        self.assertEqual(viscosity.name, "viscosity")
        self.assertEqual(viscosity.unit, "m^3/s")
        self.assertEqual((viscosity.min, viscosity.max), (0.0, 10.0))
        self.assertFalse(viscosity.integer)
        self.assertFalse(viscosity.needs_reset)
        self.assertTrue(viscosity.description)
        self.assertEqual(viscosity.solvers, ("seed",))
        self.assertTrue(viscosity.read_by("seed"))
        self.assertFalse(viscosity.read_by("dfsph"))
        self.assertEqual(params["gravity_ramp_time"].solvers, ("wcsph", "dfsph"))
        self.assertTrue(params["time_scale"].read_by("dfsph"))
        quantity = params["particle_quantity"]
        self.assertTrue(quantity.integer)
        self.assertTrue(quantity.needs_reset)
        self.assertEqual(quantity.value, 30.0)
        self.assertEqual(params["gravity"].unit, "m/s^2")

    def test_set_valid(self) -> None:
        old = self.client.params()
        try:
            self.assertFalse(self.client.set(viscosity=0.002, gravity=-9.81))
            now = self.client.params()
            self.assertEqual(now["viscosity"].value, 0.002)
            self.assertEqual(now["gravity"].value, -9.81)
            self.assertEqual(now["smoothing_radius"].value, old["smoothing_radius"].value)
            # A parameter that re-spawns the fluid.
            self.assertTrue(self.client.set_params({"particle_quantity": 20}))
            status = self.client.status()
            self.assertEqual(status.particles, 20 ** 3)
            self.assertEqual(status.frame, 0)
        finally:
            self.client.set_params({name: old[name].value for name in
                                    ("viscosity", "gravity", "particle_quantity")})
        self.assertEqual(self.client.status().particles, _PARTICLES)

    def test_set_invalid_applies_nothing(self) -> None:
        old = self.client.params()
        cases = [
            ({"viscosity": 0.003, "gravity": 1000.0}, "gravity"),  # out of range
            ({"viscosity": 0.003, "no_such_param": 1.0}, "no_such_param"),  # unknown
            ({"viscosity": 0.003, "particle_quantity": 20.5}, "particle_quantity"),  # integer
        ]
        for values, field in cases:
            with self.subTest(values=values):
                with self.assertRaises(DysaError) as caught:
                    self.client.set_params(values)
                self.assertEqual(caught.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
                self.assertIn(field, caught.exception.details)
                self.assertIn(field, str(caught.exception))
                now = self.client.params()
                self.assertEqual(now["viscosity"].value, old["viscosity"].value)
                self.assertEqual(now["particle_quantity"].value, old["particle_quantity"].value)
        self.assertEqual(self.client.status().particles, _PARTICLES)

    def test_load(self) -> None:
        loaded = self.client.load("seed_obstacles")
        self.assertEqual(loaded.status.scene, "seed_obstacles")
        self.assertEqual(loaded.status.particles, 10368)
        self.assertEqual(loaded.status.frame, 0)
        bad = [
            ('{"name": "broken", "domain": ', None),  # does not parse
            ('{"name": "typo", "fluid_blockz": []}', "fluid_blockz"),  # unknown field
            ("no_such_scene", "no_such_scene"),  # not a built-in
        ]
        for text, field in bad:
            with self.subTest(scene=text):
                with self.assertRaises(DysaError) as caught:
                    self.client.load(text)
                self.assertEqual(caught.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
                if field:
                    self.assertIn(field, caught.exception.details)
                status = self.client.status()
                self.assertEqual(status.scene, "seed_obstacles")  # the old scene keeps running
                self.assertEqual(status.particles, 10368)
        # A file on this machine (its text is sent), then a mapping.
        from_file = self.client.load(_REPO / "scenes" / "seed_basic.json")
        self.assertEqual(from_file.status.scene, _SCENE)
        self.assertEqual(from_file.status.particles, _PARTICLES)
        small = {"name": "tiny", "domain": {"min": [-1, -1, -1], "max": [1, 1, 1]},
                 "fluid_blocks": [{"center": [0, 0, 0], "particles_per_axis": 5, "size": 0.5}]}
        try:
            tiny = self.client.load(small)
            self.assertEqual(tiny.status.scene, "tiny")
            self.assertEqual(tiny.status.particles, 125)
        finally:
            self.client.load(_SCENE)

    def test_scenes(self) -> None:
        scenes = {s.name: s for s in self.client.scenes()}
        for name in ("seed_basic", "seed_test_scene", "seed_obstacles"):
            self.assertIn(name, scenes)
        self.assertEqual(scenes["seed_basic"].particles, _PARTICLES)
        self.assertEqual(scenes["seed_test_scene"].particles, 91125)
        self.assertEqual(scenes["seed_basic"].solver, "seed")
        self.assertTrue(scenes["seed_basic"].description)

    def test_get_scene(self) -> None:
        scene = self.client.get_scene()
        self.assertEqual(scene.name, _SCENE)
        self.assertTrue(scene.description)
        self.assertEqual(scene.solver, "seed")
        self.assertIn("seed", scene.solvers)
        self.assertEqual(scene.domain_min, tuple(_DOMAIN_MIN))
        self.assertEqual(scene.domain_max, tuple(_DOMAIN_MAX))
        self.assertEqual((scene.spheres, scene.boxes), ((), ()))
        self.assertAlmostEqual(scene.particle_radius, 0.5 * 5.0 / 29)  # 30 over 5 m
        self.assertEqual(scene.scene_version, self.client.status().scene_version)
        try:
            loaded = self.client.load_scene("seed_obstacles", solver="seed")
            self.assertEqual(loaded.status.solver, "seed")
            obstacles = self.client.get_scene()
            self.assertEqual(obstacles.name, "seed_obstacles")
            self.assertGreater(obstacles.scene_version, scene.scene_version)
            self.assertEqual(obstacles.scene_version, loaded.status.scene_version)
            self.assertEqual(len(obstacles.spheres), 1)
            self.assertEqual(obstacles.spheres[0].center, (0.5, -1.8, 0.8))
            self.assertEqual(obstacles.spheres[0].radius, 1.0)
            self.assertEqual(len(obstacles.boxes), 1)
            # centre [2.5, -2.25, -1.2], size [1, 1.5, 1.6]
            np.testing.assert_allclose(obstacles.boxes[0].min, (2.0, -3.0, -2.0))
            np.testing.assert_allclose(obstacles.boxes[0].max, (3.0, -1.5, -0.4))
            with self.assertRaises(DysaError) as caught:
                self.client.load(_SCENE, solver="nope")
            self.assertEqual(caught.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
            self.assertIn("solver", caught.exception.details)
            self.assertIn("seed", caught.exception.details)
            self.assertEqual(self.client.get_scene().name, "seed_obstacles")
        finally:
            self.client.load(_SCENE)

    def test_get_scene_motion(self) -> None:
        moving = {
            "name": "moving",
            "fluid_blocks": [{"center": [-3.5, -2, 0], "size": 1, "particles_per_axis": 4}],
            "obstacles": [
                {"type": "sphere", "center": [2, 0, 0], "radius": 0.5,
                 "motion": {"velocity": [0, 1.5, 0], "start": 0.1, "end": 0.5}},
                {"type": "box", "center": [0, -2, 0], "size": [1, 1, 1]},
                {"type": "box", "center": [0, 1, 0], "size": [1, 0.5, 1],
                 "motion": {"path": [[0, 0, 0, 0], [0.2, 1, 0, 0.5], [0.4, -1, 0, 0]]}},
            ],
        }
        try:
            self.client.load(moving)
            scene = self.client.get_scene()
            sphere = scene.spheres[0]
            self.assertEqual(sphere.center, (2.0, 0.0, 0.0))  # without displacement
            self.assertTrue(sphere.motion.moving)
            self.assertEqual([k.time for k in sphere.motion.keys], [0.1, 0.5])
            self.assertEqual(sphere.motion.keys[0].displacement, (0.0, 0.0, 0.0))
            np.testing.assert_allclose(sphere.motion.keys[1].displacement, (0, 0.6, 0))
            self.assertFalse(scene.boxes[0].motion.moving)
            self.assertEqual(scene.boxes[0].motion.displacement_at(0.3), (0.0, 0.0, 0.0))
            path = scene.boxes[1].motion
            self.assertEqual([(k.time, k.displacement) for k in path.keys],
                             [(0.0, (0.0, 0.0, 0.0)), (0.2, (1.0, 0.0, 0.5)),
                              (0.4, (-1.0, 0.0, 0.0))])
            # Linear between keys, held outside them.
            np.testing.assert_allclose(path.displacement_at(0.1), (0.5, 0, 0.25))
            np.testing.assert_allclose(path.displacement_at(0.3), (0, 0, 0.25), atol=1e-12)
            self.assertEqual(path.displacement_at(9.0), (-1.0, 0.0, 0.0))
            np.testing.assert_allclose(sphere.motion.displacement_at(0.0), (0, 0, 0))
            np.testing.assert_allclose(sphere.motion.displacement_at(0.3), (0, 0.3, 0))

            # The parser's error names the field; the scene stays.
            bad = json.loads(json.dumps(moving))
            bad["obstacles"][2]["motion"]["path"][2][0] = 0.1
            with self.assertRaises(DysaError) as caught:
                self.client.load(bad)
            self.assertEqual(caught.exception.code, grpc.StatusCode.INVALID_ARGUMENT)
            self.assertIn("obstacles[2].motion.path[2][0]: key times must strictly increase",
                          caught.exception.details)
            self.assertEqual(self.client.get_scene().boxes[1].motion, path)
        finally:
            self.client.load(_SCENE)

    def _check_positions(self, frame) -> None:
        self.assertEqual(frame.positions.dtype, np.float32)
        slack = np.array(frame.position_error) + 1e-4
        self.assertTrue(np.all(np.isfinite(frame.positions)))
        self.assertTrue(np.all(frame.positions >= _DOMAIN_MIN - slack))
        self.assertTrue(np.all(frame.positions <= _DOMAIN_MAX + slack))

    def test_frames_positions_only(self) -> None:
        # The earlier tests' streams are closed, but the server may still be dropping one: start
        # from none, so that the count below is this stream's alone.
        self.assertTrue(_wait_until(lambda: self.client.status().subscribers == 0))
        stream = self.client.frames(fields=("positions",), limit=3)
        self.client.resume()
        try:
            frames = _read_frames(stream, 3)
        finally:
            self.client.pause()
        self.assertTrue(stream.closed)  # the limit closes it
        for frame in frames:
            self.assertEqual(frame.count, _PARTICLES)
            self.assertEqual(frame.stride, 1)
            self.assertEqual(frame.positions.shape, (_PARTICLES, 3))
            self.assertIsNone(frame.speed)
            self.assertIsNone(frame.velocities)
            self.assertIsNone(frame.densities)
            self._check_positions(frame)
        self.assertTrue(frames[0].keyframe)  # a stream starts with a keyframe
        numbers = [f.sim_frame for f in frames]
        self.assertEqual(numbers, sorted(set(numbers)))
        times = [f.time for f in frames]
        self.assertEqual(times, sorted(times))
        # The closed stream is gone from the server.
        self.assertTrue(_wait_until(lambda: self.client.status().subscribers == 0))

    def test_frames_paused_join(self) -> None:
        # A stream starts with the current frame as a keyframe, even when paused.
        status = self.client.step(1).status
        [frame] = _read_frames(self.client.frames(fields=("positions", "speed")), 1)
        self.assertTrue(frame.keyframe)
        self.assertEqual(frame.sim_frame, status.frame)
        self.assertEqual(frame.step, status.step)
        self.assertEqual(frame.time, status.time)
        self.assertEqual(frame.speed.shape, (_PARTICLES,))
        self.assertTrue(np.all(frame.speed >= 0))

    def test_frames_all_fields(self) -> None:
        stream = self.client.frames(fields=("positions", "velocity", "density"), stride=2,
                                    position_bits=20, max_fps=30)
        self.client.resume()
        try:
            frames = _read_frames(stream, 4)
        finally:
            self.client.pause()
        n = _PARTICLES // 2 + _PARTICLES % 2  # ids 0, 2, 4, ...
        for frame in frames:
            self.assertEqual(frame.count, n)
            self.assertEqual(frame.stride, 2)
            self.assertEqual(frame.positions.shape, (n, 3))
            self.assertEqual(frame.velocities.shape, (n, 3))
            self.assertEqual(frame.densities.shape, (n,))
            self.assertIsNone(frame.speed)
            self._check_positions(frame)
            self.assertTrue(np.all(np.isfinite(frame.velocities)))
            self.assertTrue(np.all(frame.densities > 0))
            self.assertLess(max(frame.position_error), 10.0 / (2 ** 20 - 1))
        # The fluid falls: mean vertical velocity below zero after the first frames.
        self.assertLess(float(frames[-1].velocities[:, 1].mean()), 0.0)

    def test_frames_budget(self) -> None:
        # A particle budget: a stable subset by rank, the same ids in every frame, each frame
        # naming them; GetStatus reports the stream. (No fps_target: the detail then follows
        # the particle count alone, whatever the machine's load does to the link.)
        stream = self.client.frames(fields=("positions",), max_fps=30,
                                    particle_budget=_PARTICLES // 4)
        self.client.resume()
        try:
            frames = _read_frames(stream, 3, keep_open=True)
            status = self.client.status()
        finally:
            self.client.pause()
            stream.close()
        for frame in frames:
            self.assertLess(frame.detail_fraction, 0.26)
            self.assertLessEqual(frame.count, _PARTICLES // 4 * 1.2)
            self.assertEqual(frame.ids.shape, (frame.count,))
            self.assertTrue(np.array_equal(frame.ids, frames[0].ids))
            self.assertTrue(np.all(detail.detail_rank(frame.ids) < frame.detail_threshold))
            self._check_positions(frame)
        self.assertFalse(frames[1].keyframe)  # delta coding goes on within the subset
        [s] = [s for s in status.streams if s.particle_budget == _PARTICLES // 4]
        self.assertEqual(s.fps_target, 0)
        self.assertAlmostEqual(s.detail, frames[-1].detail_fraction, places=6)
        # Without budgets, ids are 0 .. count - 1 and the detail is whole.
        [whole] = _read_frames(self.client.frames(fields=("positions",)), 1)
        self.assertEqual(whole.detail_fraction, 1.0)
        self.assertTrue(np.array_equal(whole.ids, np.arange(_PARTICLES)))

    def test_frames_view_completes_on_pause(self) -> None:
        # A camera: the view's subset, then (paused) refinements until the frame is complete,
        # bit-exactly the full-detail frame, within log2(27000 / 1000) + 1 refinements.
        [full] = _read_frames(self.client.frames(fields=("positions",)), 1)
        stream = self.client.frames(fields=("positions",), particle_budget=1000)
        try:
            [first] = _read_frames(stream, 1, keep_open=True)
            self.assertGreater(stream.stream_id, 0)
            with self.assertRaises(DysaError) as caught:
                self.client.set_stream_view(stream.stream_id, (0, 2, 12), (0, 0, 0), aspect=100)
            self.assertIn("aspect: allowed range [0.05, 20]", str(caught.exception))
            stream.set_view((0.0, 2.0, 12.0), (0.0, -1.0, 0.0), fov_y_deg=30, aspect=1.5)
            [s] = [s for s in self.client.status().streams if s.stream_id == stream.stream_id]
            self.assertTrue(s.view)
            frames = []
            while not frames or frames[-1].partial or not frames[-1].explicit_ids:
                frames += _read_frames(stream, 1, keep_open=True)
                self.assertLessEqual(len(frames), 1 + 6 + 2)
        finally:
            stream.close()
        view_frames = [f for f in frames if f.explicit_ids]
        # The view's subset once (setting the camera asks for one keyframe), then only
        # refinements of it.
        self.assertLessEqual(view_frames[0].count, 1000)
        self.assertFalse(view_frames[0].refined)
        self.assertTrue(all(f.refined for f in view_frames[1:]))
        done = frames[-1]
        self.assertEqual(done.sim_frame, first.sim_frame)
        self.assertTrue(np.array_equal(done.ids, np.arange(_PARTICLES)))
        self.assertTrue(np.array_equal(done.positions.view(np.uint32),
                                       full.positions.view(np.uint32)))

    def test_frames_octahedral_velocity(self) -> None:
        with self.assertRaisesRegex(ValueError, "velocity_encoding must be one of components, "
                                                "octahedral"):
            self.client.frames(fields=("velocity",), velocity_encoding="polar")
        stream = self.client.frames(fields=("velocity",), velocity_encoding="octahedral",
                                    max_fps=30)
        self.client.resume()
        try:
            frames = _read_frames(stream, 3)
        finally:
            self.client.pause()
        for frame in frames:
            self.assertEqual(frame.velocity_encoding, "octahedral")
            self.assertEqual(frame.velocities.shape, (_PARTICLES, 3))
            self.assertTrue(np.all(np.isfinite(frame.velocities)))
            self.assertGreater(frame.velocity_error, 0.0)
        self.assertLess(float(frames[-1].velocities[:, 1].mean()), 0.0)

    def test_examples(self) -> None:
        examples = _CLIENT / "examples"
        with tempfile.TemporaryDirectory() as tmp:
            summary = Path(tmp) / "sweep.csv"
            result = subprocess.run(
                [sys.executable, str(examples / "param_sweep.py"), "--server",
                 self.server.address, "--values", "0.0005,0.01", "--frames", "3",
                 "--csv", str(summary)],
                env=_child_env(), capture_output=True, text=True, timeout=300)
            self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
            with open(summary, newline="", encoding="utf-8") as f:
                rows = list(csv.reader(f))
            self.assertEqual(rows[0][0], "viscosity")
            self.assertEqual([float(r[0]) for r in rows[1:]], [0.0005, 0.01])
            for row in rows[1:]:
                self.assertEqual(int(row[1]), 3)
                self.assertGreater(float(row[3]), 0.0)  # the fluid falls: it has energy
            self.assertEqual(self.client.params()["viscosity"].value, 0.001)  # put back

            out = Path(tmp) / "rec.npz"
            result = subprocess.run(
                [sys.executable, str(examples / "record_npz.py"), "--server",
                 self.server.address, "--frames", "3", "--resume", "--duration", "120",
                 "--stride", "3", "--out", str(out)],
                env=_child_env(), capture_output=True, text=True, timeout=300)
            self.client.pause()
            self.assertEqual(result.returncode, 0, result.stdout + result.stderr)
            with np.load(out) as data:
                self.assertEqual(data["positions"].shape, (3, _PARTICLES // 3, 3))
                self.assertEqual(data["speed"].shape, (3, _PARTICLES // 3))
                for key in ("time", "step", "frame"):
                    self.assertEqual(data[key].shape, (3,))
                self.assertTrue(np.all(np.diff(data["frame"]) > 0))


def _python_block(markdown: Path, marker: str) -> str:
    """The ```python block of `markdown` that contains `marker`, as written."""
    for block in re.findall(r"```python\n(.*?)```", markdown.read_text(encoding="utf-8"), re.S):
        if marker in block:
            return block
    raise AssertionError("no python block with %r in %s" % (marker, markdown))


class DocumentationTest(unittest.TestCase):
    """The documentation's client examples, as written, run from a checkout whose build is in
    neither build/release nor DYSA_PYTHON_STUBS (they failed unless it was in build/release)."""

    def test_snippets_run_from_any_build_directory(self) -> None:
        snippets = [
            (_REPO / "docs" / "server.md", "from dysa.client import Client\n"),
            (_CLIENT / "README.md", "from dysa.client import Client, DysaError\n"),
        ]
        stubs = Path(os.environ.get("DYSA_PYTHON_STUBS", _REPO / "build" / "release" / "python"))
        server = Server("--threads", "2", "--paused")
        try:
            with tempfile.TemporaryDirectory() as tmp:
                checkout = Path(tmp)
                shutil.copytree(_CLIENT / "dysa", checkout / "clients" / "python" / "dysa",
                                ignore=shutil.ignore_patterns("__pycache__"))
                shutil.copytree(stubs / "dysa" / "v1",
                                checkout / "build" / "gcc-debug" / "python" / "dysa" / "v1")
                env = {k: v for k, v in os.environ.items()
                       if k not in ("DYSA_PYTHON_STUBS", "PYTHONPATH")}
                env["PYTHONPATH"] = "clients/python"  # as the documentation says
                for markdown, marker in snippets:
                    code = _python_block(markdown, marker).replace("127.0.0.1:50051",
                                                                   server.address)
                    result = subprocess.run(["/usr/bin/python3", "-c", code], cwd=checkout,
                                            env=env, capture_output=True, text=True, timeout=120)
                    self.assertEqual(result.returncode, 0, "%s:\n%s%s" % (
                        markdown, result.stdout, result.stderr))
        finally:
            code = server.stop()
            log = server.log()
            server.close()
        self.assertEqual(code, 0, log)


class TokenTest(unittest.TestCase):
    """A server started with --token-file --protect-watch, and its shutdown with a stream
    open."""

    TOKEN = "s3cret-token"

    def setUp(self) -> None:
        self.token_dir = tempfile.TemporaryDirectory()
        token_file = Path(self.token_dir.name) / "token"
        token_file.write_text(self.TOKEN + "\n")
        self.server = Server("--token-file", str(token_file), "--protect-watch", "--paused")

    def tearDown(self) -> None:
        self.server.close()
        self.token_dir.cleanup()

    def test_token(self) -> None:
        for token in (None, "wrong"):
            with self.subTest(token=token), Client(self.server.address, token=token) as c:
                for verb in (c.pause, c.status, c.params):
                    with self.assertRaises(DysaError) as caught:
                        verb()
                    self.assertEqual(caught.exception.code, grpc.StatusCode.UNAUTHENTICATED)
                    self.assertIn("token", str(caught.exception))
                with self.assertRaises(DysaError) as caught:
                    next(iter(c.frames()))
                self.assertEqual(caught.exception.code, grpc.StatusCode.UNAUTHENTICATED)

        with Client(self.server.address, token=self.TOKEN) as client:
            self.assertTrue(client.pause().status.paused)
            self.assertEqual(client.step(2).frames_moved, 2)
            self.assertIn("viscosity", client.params())
            # Shutdown with a stream open: the stream ends with UNAVAILABLE, the exit is clean.
            stream = client.frames(fields=("positions",))
            client.resume()
            _read_frames(stream, 1, keep_open=True)
            self.assertEqual(self.server.stop(), 0, self.server.log())
            with self.assertRaises(DysaError) as caught:
                for _ in stream:
                    pass
            self.assertEqual(caught.exception.code, grpc.StatusCode.UNAVAILABLE)


class TlsTest(unittest.TestCase):
    """A server started with --tls-cert/--tls-key, reached with tls_ca."""

    def test_tls(self) -> None:
        with tempfile.TemporaryDirectory() as tmp:
            cert, key = Path(tmp) / "cert.pem", Path(tmp) / "key.pem"
            subprocess.run(
                ["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1",
                 "-subj", "/CN=localhost", "-addext", "subjectAltName=DNS:localhost",
                 "-keyout", str(key), "-out", str(cert)],
                check=True, capture_output=True, timeout=60)
            server = Server("--tls-cert", str(cert), "--tls-key", str(key), "--paused")
            try:
                # The certificate names localhost; the address is 127.0.0.1.
                with Client(server.address, tls_ca=cert, tls_server_name="localhost") as c:
                    self.assertEqual(c.status().scene, _SCENE)
                    self.assertEqual(c.step(1).frames_moved, 1)
                    [frame] = _read_frames(c.frames(fields=("positions",)), 1)
                    self.assertEqual(frame.positions.shape, (_PARTICLES, 3))
                # Plain TCP to a TLS server fails with UNAVAILABLE, naming the address.
                with Client(server.address, timeout=10) as plain:
                    with self.assertRaises(DysaError) as caught:
                        plain.status()
                    self.assertEqual(caught.exception.code, grpc.StatusCode.UNAVAILABLE)
                    self.assertIn(server.address, str(caught.exception))
                self.assertEqual(server.stop(), 0, server.log())
            finally:
                server.close()


if __name__ == "__main__":
    unittest.main()
