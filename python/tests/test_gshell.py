"""Tests of the gshell Python module: results agree with the CLI's on the same input, invariants
hold (rigid motions, round trips), and bad arguments raise ValueError instead of crashing.

Run by CTest with PYTHONPATH=<build>/python and GSHELL_CLI=<build>/bin/gshell, or by hand:
    PYTHONPATH=build/python GSHELL_CLI=build/bin/gshell /usr/bin/python3 -m unittest -v test_gshell
(from python/tests).
"""
import ast
import json
import math
import os
import pathlib
import pickle
import re
import shutil
import subprocess
import sys
import tempfile
import textwrap
import threading
import unittest

import numpy as np

import gshell

CLI = os.environ.get("GSHELL_CLI", "")


def run_cli(*args):
    """Runs the gshell CLI and returns its stdout; fails the test on a non-zero exit."""
    r = subprocess.run([CLI, *args], capture_output=True, text=True)
    if r.returncode != 0:
        raise AssertionError(f"gshell {' '.join(args)} exited {r.returncode}: {r.stderr}")
    return r.stdout


def rotation(axis, degrees):
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    a = math.radians(degrees)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * K @ K


# Keys that differ between a CLI run and the same run from Python by nature: how the inputs are
# named (files vs arrays; a written pose folder's path to its rest shell, which a result in memory
# has not), the version, and wall-clock timings.
NAME_KEYS = {"input", "shell", "rest_shell", "base", "handles", "gshell_version"}


def is_timing(key):
    return "seconds" in key


def assert_same_report(test, cli, mine, path="report"):
    """The same keys at every level and the same values (numbers to 1e-9 relative), except names
    and timings."""
    if isinstance(cli, dict):
        test.assertIsInstance(mine, dict, path)
        keep = lambda d: {k for k in d if k not in NAME_KEYS and not is_timing(k)}
        test.assertEqual(keep(cli), keep(mine), path)
        for key in keep(cli):
            assert_same_report(test, cli[key], mine[key], f"{path}.{key}")
    elif isinstance(cli, list):
        test.assertIsInstance(mine, list, path)
        test.assertEqual(len(cli), len(mine), path)
        for i, (a, b) in enumerate(zip(cli, mine)):
            assert_same_report(test, a, b, f"{path}[{i}]")
    elif isinstance(cli, bool) or cli is None or isinstance(cli, str):
        test.assertEqual(cli, mine, path)
    elif isinstance(cli, (int, float)):
        test.assertIsInstance(mine, (int, float), path)
        test.assertAlmostEqual(cli, mine, delta=1e-9 * max(1.0, abs(cli)), msg=path)
    else:
        test.fail(f"{path}: unexpected {cli!r}")


def count_numbers(report):
    """Numbers compared by assert_same_report (so a test can show it compared something)."""
    if isinstance(report, dict):
        return sum(count_numbers(v) for k, v in report.items() if k not in NAME_KEYS and not is_timing(k))
    if isinstance(report, list):
        return sum(count_numbers(v) for v in report)
    return int(isinstance(report, (int, float)) and not isinstance(report, bool))


def keyword_defaults(function):
    """{keyword: default} from a pybind11 signature line, e.g. "f(x, *, n: int = 5) -> None"."""
    signature = function.__doc__.splitlines()[0]
    return {name: ast.literal_eval(value) for name, value in
            re.findall(r"(\w+): [\w.\[\]]+ = ('[^']*'|[-+\w.]+)", signature) if value != "None"}


def flag_defaults(command):
    """{flag: default text} from `gshell COMMAND --help` (CLI11 shows "--flag TYPE=DEFAULT")."""
    return dict(re.findall(r"^\s+(--[\w-]+) [^\s=]+=(\S+)", run_cli(command, "--help"), re.MULTILINE))


class LabelledShell(gshell.Shell):
    """A user's subclass: pickling must keep its type and attributes (at module level to be picklable)."""


class DefaultsTest(unittest.TestCase):
    """The CLI and Python read their defaults from the same library options (one source)."""

    def assert_same_defaults(self, command, function, pairs):
        flags, keywords = flag_defaults(command), keyword_defaults(function)
        for flag, keyword in pairs:
            with self.subTest(command=command, flag=flag):
                default = keywords[keyword]
                shown = flags[flag]
                self.assertEqual(type(default)(shown) if not isinstance(default, str) else shown, default)

    def test_generate(self):
        self.assert_same_defaults("generate", gshell.generate, [
            ("--method", "method"), ("--iterations", "iterations"), ("--tolerance", "tolerance"),
            ("--s-min", "s_min"), ("--s-max", "s_max")])

    def test_deform(self):
        self.assert_same_defaults("deform", gshell.Deformer.solve, [
            ("--iterations", "iterations"), ("--tolerance", "tolerance"), ("--warm-start", "warm_start")])
        self.assert_same_defaults("deform", gshell.deform, [
            ("--iterations", "iterations"), ("--tolerance", "tolerance"), ("--warm-start", "warm_start")])
        self.assertEqual(keyword_defaults(gshell.Deformer.solve)["warm_start"], "extrapolated")

    def test_pose(self):
        self.assert_same_defaults("pose", gshell.Poser.solve, [
            ("--steps", "steps"), ("--iterations", "iterations"), ("--tolerance", "tolerance")])
        self.assert_same_defaults("pose", gshell.Poser.__init__, [("--solver", "solver"), ("--levels", "levels")])
        self.assertEqual(keyword_defaults(gshell.Poser.solve)["iterations"], 500)
        self.assertEqual(keyword_defaults(gshell.Poser.solve)["tolerance"], 1e-6)


class TempDirTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="gshell_py_")

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def path(self, name):
        return os.path.join(self.tmp, name)


class DocstringTest(unittest.TestCase):
    def test_everything_public_is_documented(self):
        self.assertGreater(len(gshell.__doc__), 100)
        names = [n for n in dir(gshell) if not n.startswith("_")]
        self.assertTrue({"read_mesh", "write_mesh", "builtin", "weld", "generate", "metrics", "load_shell", "Shell",
                         "Deformer", "Poser", "Embedding", "embed"} <= set(names))
        for name in names:
            obj = getattr(gshell, name)
            with self.subTest(name):
                self.assertTrue((obj.__doc__ or "").strip(), name)
            if isinstance(obj, type):
                for member, value in vars(obj).items():
                    if member.startswith("_") and member not in ("__init__", "__len__", "__repr__"):
                        continue
                    with self.subTest(f"{name}.{member}"):
                        self.assertTrue((getattr(value, "__doc__", None) or "").strip(), f"{name}.{member}")


class MeshIOTest(TempDirTest):
    def test_builtin_sizes_and_types(self):
        for level in range(4):
            V, F = gshell.builtin(f"sphere:{level}")
            self.assertEqual(V.shape, (10 * 4**level + 2, 3))
            self.assertEqual(F.shape, (20 * 4**level, 3))
            self.assertEqual(V.dtype, np.float64)
            self.assertEqual(F.dtype, np.int64)
            np.testing.assert_allclose(np.linalg.norm(V, axis=1), 1.0, atol=1e-12)
        V1, F1 = gshell.builtin("builtin:torus:16")
        V2, F2 = gshell.builtin("torus:16")
        np.testing.assert_array_equal(V1, V2)
        np.testing.assert_array_equal(F1, F2)
        self.assertEqual(V1.shape, (16 * 8, 3))

    def test_read_mesh_takes_builtin_specs(self):
        V, F = gshell.read_mesh("builtin:torus:12")
        V2, F2 = gshell.builtin("torus:12")
        np.testing.assert_array_equal(V, V2)
        np.testing.assert_array_equal(F, F2)

    def test_round_trip_every_format(self):
        V, F = gshell.builtin("torus:12")
        for ext in ("obj", "off", "ply"):
            p = self.path("m." + ext)
            gshell.write_mesh(p, V, F)
            V2, F2 = gshell.read_mesh(p)
            np.testing.assert_array_equal(V2, V)  # writers keep full precision
            np.testing.assert_array_equal(F2, F)

    def test_accepts_other_layouts_and_dtypes(self):
        V, F = gshell.builtin("sphere:1")
        p = self.path("m.obj")
        # Fortran order, float32, int32, a strided view, Python lists: all are fine.
        gshell.write_mesh(p, np.asfortranarray(V), F.astype(np.int32))
        np.testing.assert_array_equal(gshell.read_mesh(p)[0], V)
        gshell.write_mesh(p, V.astype(np.float32), F.astype(np.uint16))
        np.testing.assert_allclose(gshell.read_mesh(p)[0], V, atol=1e-6)
        wide = np.hstack([V, np.zeros((len(V), 1))])
        gshell.write_mesh(p, wide[:, :3], F[::-1])
        np.testing.assert_array_equal(gshell.read_mesh(p)[1], F[::-1])
        gshell.write_mesh(p, V.tolist(), F.tolist())
        np.testing.assert_array_equal(gshell.read_mesh(p)[0], V)

    def test_weld_joins_a_triangle_soup_that_generate_warns_of(self):
        V, F = gshell.builtin("sphere:2")
        soup_V, soup_F = V[F.reshape(-1)], np.arange(3 * len(F)).reshape(-1, 3)
        cut = gshell.generate(soup_V, soup_F, thickness_ratio=0.05)
        self.assertTrue(any("same position but not joined" in w for w in cut.report["warnings"]),
                        cut.report["warnings"])
        W, G = gshell.weld(soup_V, soup_F)
        self.assertEqual(W.shape, V.shape)
        np.testing.assert_array_equal(W[G], V[F])  # every face corner where it was
        whole = gshell.generate(W, G, thickness_ratio=0.05)
        self.assertTrue(whole.report["valid"])
        self.assertEqual(whole.report["warnings"], [])

    def test_read_matches_cli_output(self):
        out = self.path("shell")
        run_cli("generate", "builtin:sphere:2", "-o", out, "--thickness", "0.05", "--quiet")
        V, F = gshell.read_mesh(os.path.join(out, "base.obj"))
        Vb, Fb = gshell.builtin("sphere:2")
        np.testing.assert_array_equal(V, Vb)
        np.testing.assert_array_equal(F, Fb)

    def test_arrays_too_large_to_copy_raise_memory_error_not_an_internal_error(self):
        V, F = gshell.builtin("sphere:1")
        huge = np.broadcast_to(np.array([0.1, 0.2, 0.3]), (10**12, 3))  # no memory behind it
        with self.assertRaises((MemoryError, ValueError)):
            gshell.write_mesh(self.path("x.obj"), huge, F)
        shell = gshell.generate(V, F, thickness=0.1)
        with self.assertRaises((MemoryError, ValueError)):
            gshell.embed(shell, huge)

    def test_bad_arguments_raise_value_error(self):
        V, F = gshell.builtin("sphere:1")
        p = self.path("bad.obj")
        bad = [
            (V.astype(np.int64), F, "dtype"),
            (V[:, :2], F, "shape"),
            (V.reshape(-1), F, "shape"),
            (V, F.astype(float), "dtype"),
            (V, F[:, :2], "shape"),
            (V, F + len(V), "index"),
            (V, -F, "index"),
            (V, F.astype(bool), "dtype"),
            (V.astype(complex), F, "dtype"),
            (np.where(V > 0.9, np.nan, V), F, "finite"),
            (np.where(V > 0.9, np.inf, V), F, "finite"),
            ("not an array", F, "dtype"),
            (V, None, "dtype"),
            (V, np.full((2, 3), 2**40), "index"),
            (V * 1e60, F, "1e+50"),
        ]
        for Vx, Fx, word in bad:
            with self.subTest(word=word):
                with self.assertRaises(ValueError) as cm:
                    gshell.write_mesh(p, Vx, Fx)
                self.assertIn(word, str(cm.exception).lower() if word != "finite" else str(cm.exception))
        self.assertFalse(os.path.exists(p))
        # Unsigned ids from 2^63 up are named as given (they wrapped to negative numbers).
        with self.assertRaisesRegex(ValueError, r"^F\[0, 2\] = 9223372036854775808 is not a valid index"):
            gshell.write_mesh(p, V, np.array([[0, 1, 2**63]], dtype=np.uint64))
        with self.assertRaises(ValueError):
            gshell.write_mesh(self.path("m.xyz"), V, F)
        with self.assertRaises(ValueError):
            gshell.write_mesh(self.path("no/such/folder/m.obj"), V, F)
        with self.assertRaises(ValueError):
            gshell.read_mesh(self.path("missing.obj"))
        with open(p, "w") as f:
            f.write("v 0 0 0\nv 1 0 0\nf 1 2 7\n")
        with self.assertRaises(ValueError):
            gshell.read_mesh(p)
        # A NaN read from a file is named with the file and vertex, as `gshell convert` names it.
        with open(p, "w") as f:
            f.write("v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n")
        with self.assertRaisesRegex(ValueError, r"bad\.obj: vertex 1 has a non-finite coordinate"):
            gshell.read_mesh(p)
        # A path with a NUL byte is named as such, not as an argument type the call does not take.
        for call in (lambda: gshell.read_mesh("m\0.obj"), lambda: gshell.write_mesh("m\0.obj", V, F),
                     lambda: gshell.load_shell(path="dir\0")):
            with self.assertRaisesRegex(ValueError, r"^\w+\(\): \w+: embedded null byte$"):
                call()

        class BrokenPath:
            def __fspath__(self):
                raise ZeroDivisionError("mine")
        with self.assertRaisesRegex(ZeroDivisionError, "mine"):
            gshell.read_mesh(BrokenPath())
        # An array-like whose __array__ raises: its own error; NumPy's refusal of a ragged list: one line.
        class BrokenArray:
            def __array__(self, dtype=None, copy=None):
                raise ZeroDivisionError("mine")
        with self.assertRaisesRegex(ZeroDivisionError, "mine"):
            gshell.write_mesh(p, BrokenArray(), F)
        with self.assertRaisesRegex(ValueError, r"^V is not an array: [^\n]+$"):
            gshell.write_mesh(p, [[0, 0, 0], [1, 0]], F)
        for spec in ("teapot", "sphere:99", "sphere:x", ""):
            with self.subTest(spec=spec), self.assertRaises(ValueError):
                gshell.builtin(spec)


class GenerateTest(TempDirTest):
    def cli_shell(self, spec, *options):
        out = self.path("cli_" + spec.replace(":", "_") + "_" + str(len(os.listdir(self.tmp))))
        run_cli("generate", spec, "-o", out, "--quiet", *options)
        top, _ = gshell.read_mesh(os.path.join(out, "top.obj"))
        with open(os.path.join(out, "report.json")) as f:
            report = json.load(f)
        return out, top, report

    def test_allow_invalid_agrees_with_cli_and_skips_the_guard(self):
        # A V fold (30 degrees) whose paper shell crosses itself: the guard makes it valid.
        V, F = gshell.builtin("plane:8")
        half = math.radians(15)
        V = np.column_stack([V[:, 0] * math.sin(half), V[:, 1], np.abs(V[:, 0]) * math.cos(half)])
        guarded = gshell.generate(V, F, thickness=0.1)
        unguarded = gshell.generate(V, F, thickness=0.1, allow_invalid=True)
        self.assertTrue(guarded.report["guarded"])
        self.assertTrue(guarded.report["valid"])
        self.assertFalse(unguarded.report["guarded"])
        self.assertFalse(unguarded.report["valid"])
        self.assertTrue(unguarded.report["warnings"])
        path = self.path("fold.obj")
        gshell.write_mesh(path, V, F)
        out = self.path("fold_cli")
        run_cli("generate", path, "-o", out, "--quiet", "--thickness", "0.1", "--allow-invalid")
        top, _ = gshell.read_mesh(os.path.join(out, "top.obj"))
        with open(os.path.join(out, "report.json")) as f:
            report = json.load(f)
        np.testing.assert_allclose(top, unguarded.top, atol=1e-9, rtol=0)
        self.assertFalse(report["guarded"])
        self.assertFalse(report["valid"])

    def test_agrees_with_cli_sphere(self):
        _, top, report = self.cli_shell("builtin:sphere:3", "--thickness", "0.05")
        V, F = gshell.builtin("sphere:3")
        shell = gshell.generate(V, F, thickness=0.05)
        np.testing.assert_allclose(shell.top, top, atol=1e-9, rtol=0)
        assert_same_report(self, report, shell.report)
        self.assertEqual(shell.report["input"], "<numpy arrays>")

    def test_agrees_with_cli_ratio_and_methods(self):
        V, F = gshell.builtin("torus:24")
        for method in ("offset", "rigid", "curvature"):
            with self.subTest(method=method):
                # The offset is not optimised: the CLI refuses iteration options with it.
                solve = [] if method == "offset" else ["--iterations", "7", "--tolerance", "1e-7"]
                _, top, report = self.cli_shell(
                    "builtin:torus:24", "--thickness-ratio", "0.02", "--method", method, *solve)
                keywords = {} if method == "offset" else {"iterations": 7, "tolerance": 1e-7}
                shell = gshell.generate(V, F, thickness_ratio=0.02, method=method, **keywords)
                np.testing.assert_allclose(shell.top, top, atol=1e-9, rtol=0)
                assert_same_report(self, report, shell.report)
                self.assertEqual(shell.report["method"], method)
                self.assertEqual("curvature" in shell.report, method == "curvature")

    def test_curvature_clamps_and_report_section_agree_with_cli(self):
        # Thick enough that the torus' inner equator hits s_min = 0.8 (it wants about 1 - 0.3 / 0.6).
        V, F = gshell.builtin("torus:24")
        _, top, report = self.cli_shell("builtin:torus:24", "--thickness", "0.3", "--method", "curvature",
                                        "--s-min", "0.8", "--s-max", "1.5")
        shell = gshell.generate(V, F, thickness=0.3, method="curvature", s_min=0.8, s_max=1.5)
        np.testing.assert_allclose(shell.top, top, atol=1e-9, rtol=0)
        assert_same_report(self, report, shell.report)
        c = shell.report["curvature"]
        self.assertEqual((c["s_min"], c["s_max"]), (0.8, 1.5))
        self.assertGreater(c["clamped_prisms"], 0)
        self.assertGreater(c["own_prisms"]["stretch"]["volume_mean"], 0)
        # Against its own prisms it is closer than against the normal ones (what it optimised).
        self.assertLess(c["own_prisms"]["stretch"]["volume_mean"], shell.report["stretch"]["volume_mean"])
        with self.assertRaises(ValueError) as cm:
            gshell.generate(V, F, thickness=0.3, method="curvature", s_min=1.2)
        self.assertIn("s_min", str(cm.exception))
        # A clamp given to a method without one is refused, as the CLI refuses it (it was ignored);
        # left out, the curvature method uses the default the signature shows.
        for method in ("rigid", "offset"):
            for clamp in ("s_min", "s_max"):
                with self.subTest(method=method, clamp=clamp), \
                        self.assertRaisesRegex(ValueError, "^" + clamp + " applies only to method='curvature'$"):
                    gshell.generate(V, F, thickness=0.3, method=method, **{clamp: 1.0})
        c = gshell.generate(V, F, thickness=0.3, method="curvature").report["curvature"]
        defaults = keyword_defaults(gshell.generate)
        self.assertEqual((c["s_min"], c["s_max"]), (defaults["s_min"], defaults["s_max"]))

    def test_options_a_run_would_ignore_are_errors(self):
        # As the CLI's flags: the offset is not optimised, and the unguarded run is the paper's plain
        # iteration from the plain offset. Given even at the signature's default, they are refused.
        V, F = gshell.builtin("sphere:1")
        defaults = keyword_defaults(gshell.generate)
        optimised = "applies only to method='rigid' or 'curvature'$"
        for name in ("iterations", "tolerance", "anderson", "start_smoothing"):
            with self.subTest(name=name), self.assertRaisesRegex(ValueError, "^" + name + " " + optimised):
                gshell.generate(V, F, thickness=0.1, method="offset", **{name: defaults[name]})
        with self.assertRaisesRegex(ValueError, "^allow_invalid " + optimised):
            gshell.generate(V, F, thickness=0.1, method="offset", allow_invalid=True)
        for name in ("anderson", "start_smoothing"):
            with self.subTest(name=name), self.assertRaisesRegex(
                    ValueError, "^" + name + r" applies only to guarded runs \(not with allow_invalid=True\)$"):
                gshell.generate(V, F, thickness=0.1, allow_invalid=True, **{name: defaults[name]})
        # Where they apply, given at their defaults they are the run left alone.
        given = gshell.generate(V, F, thickness=0.1, **{name: defaults[name] for name in
                                                     ("iterations", "tolerance", "anderson", "start_smoothing")})
        np.testing.assert_array_equal(given.top, gshell.generate(V, F, thickness=0.1).top)
        gshell.generate(V, F, thickness=0.1, method="offset", allow_invalid=False)

    def test_shells_pickle_as_they_are(self):
        # multiprocessing and caches pickle shells: the same arrays, stretch and report come back,
        # without measuring again, and the copy deforms as the original does.
        V, F = gshell.builtin("sphere:2")
        shell = gshell.generate(V, F, thickness=0.1)
        copy = pickle.loads(pickle.dumps(shell))
        for name in ("base", "top", "faces", "tets", "stretch"):
            np.testing.assert_array_equal(getattr(copy, name), getattr(shell, name), err_msg=name)
        self.assertEqual(copy.thickness, shell.thickness)
        self.assertEqual(copy.report, shell.report)
        np.testing.assert_array_equal(gshell.Deformer(copy).solve(V * 1.05), gshell.Deformer(shell).solve(V * 1.05))
        with self.assertRaisesRegex(ValueError, "not the state of a pickled gshell.Shell"):
            gshell.Shell.__new__(gshell.Shell).__setstate__((0,))
        # A subclass comes back as itself with its attributes (they were dropped), and a state of
        # the previous version (no attributes) still loads.
        labelled = LabelledShell(shell.base, shell.faces, shell.top, shell.thickness)
        labelled.label = "left ear"
        copy = pickle.loads(pickle.dumps(labelled))
        self.assertIs(type(copy), LabelledShell)
        self.assertEqual(copy.label, "left ear")
        np.testing.assert_array_equal(copy.top, shell.top)
        older = gshell.Shell.__new__(gshell.Shell)
        older.__setstate__((2,) + tuple(shell.__getstate__()[1:10]))
        np.testing.assert_array_equal(older.top, shell.top)
        state = list(shell.__getstate__())
        state[6] = "{not json"
        with self.assertRaisesRegex(ValueError, "^Shell: the pickled report is not a JSON object$"):
            gshell.Shell.__new__(gshell.Shell).__setstate__(tuple(state))
        # A state changed by hand gets the checks Shell(...) makes: here a face given twice.
        state = list(shell.__getstate__())
        state[2] = np.vstack([state[2], state[2][:1]])
        state[5] = np.concatenate([state[5], state[5][:3]])
        with self.assertRaisesRegex(ValueError, "^Shell state: base: .*(duplicate|twice|non-manifold)"):
            gshell.Shell.__new__(gshell.Shell).__setstate__(tuple(state))
        state = list(shell.__getstate__())
        state[3] = state[3] * 1e60
        with self.assertRaisesRegex(ValueError, "top"):
            gshell.Shell.__new__(gshell.Shell).__setstate__(tuple(state))

    def test_a_shell_from_a_folder_not_named_in_utf8_pickles_and_names_it_in_errors(self):
        folder = os.fsencode(self.tmp) + b"/caf\xe9"
        subprocess.run([CLI, "generate", "builtin:sphere:1", "-o", folder, "--thickness", "0.1", "--quiet"],
                       capture_output=True, check=True)  # bytes: its summary names the folder
        shell = gshell.load_shell(os.fsdecode(folder))
        copy = pickle.loads(pickle.dumps(shell))  # was UnicodeDecodeError
        np.testing.assert_array_equal(copy.top, shell.top)
        # An error naming such a path keeps its message (it was a ValueError without one).
        with self.assertRaises(ValueError) as caught:
            gshell.read_mesh(os.fsdecode(folder + b"/missing.obj"))
        self.assertIn("caf\\xe9/missing.obj", str(caught.exception))

    def test_a_forked_process_can_generate_after_its_parent_did(self):
        # GNU OpenMP's pool (CHOLMOD's) does not survive fork: a child's factorisation hung for
        # good, which is what multiprocessing's default start method on Linux does to workers.
        V, F = gshell.builtin("sphere:2")
        gshell.generate(V, F, thickness=0.1)
        child = os.fork()
        if child == 0:
            import signal
            signal.alarm(60)
            try:
                gshell.generate(V, F, thickness=0.1)
                os._exit(0)
            except BaseException:
                os._exit(1)
        _, status = os.waitpid(child, 0)
        self.assertEqual(os.waitstatus_to_exitcode(status), 0)

    def test_the_interpreter_exits_cleanly_while_a_daemon_thread_solves(self):
        # CPython unwinds a daemon thread that takes the GIL back during finalisation; through the
        # module's frames that aborted the process (or the solve raced OpenBLAS's shutdown: a
        # segfault), in about one exit of four. The exit now stops the solve at its next iteration.
        script = textwrap.dedent("""
            import threading, gshell
            V, F = gshell.builtin("sphere:4")
            shell = gshell.generate(V, F, thickness_ratio=0.03)
            low = V[:, 2].min() + 0.3
            H = {"handles": [{"select": {"surface": "both", "box": [-9, -9, -9, 9, 9, low]}},
                             {"select": {"surface": "both", "box": [-9, -9, -low, 9, 9, 9]},
                              "rotate": {"axis": [1, 0, 0], "degrees": 60}}]}
            solving = threading.Event()
            def work(progress):
                gshell.Poser(shell).solve(H, steps=1000, tolerance=0, progress=progress)
            threading.Thread(target=work, args=(lambda u: solving.set(),), daemon=True).start()
            threading.Thread(target=work, args=(None,), daemon=True).start()
            solving.wait()
            print("exiting")
        """)
        for _ in range(4):
            r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
            self.assertEqual((r.returncode, r.stdout, r.stderr), (0, "exiting\n", ""))

    def test_objects_made_without_init_are_refused(self):
        # pickle and copy make objects with __new__; used before __setstate__ (or __init__) they held
        # uninitialised memory ("array is too big", bad_alloc, embed running on garbage).
        message = r"^gshell\.{} object is not initialised \(made by __new__ without __init__ or __setstate__\)$"
        bare = gshell.Shell.__new__(gshell.Shell)
        for call in (lambda: bare.faces, lambda: repr(bare), lambda: gshell.Deformer(bare),
                     lambda: gshell.embed(bare, np.zeros((1, 3)))):
            with self.assertRaisesRegex(TypeError, message.format("Shell")):
                call()
        with self.assertRaisesRegex(TypeError, message.format("Deformer")):
            gshell.Deformer.__new__(gshell.Deformer).solve(np.zeros((3, 3)))
        with self.assertRaisesRegex(TypeError, message.format("Poser")):
            gshell.Poser.__new__(gshell.Poser).reset()
        with self.assertRaisesRegex(TypeError, message.format("Embedding")):
            gshell.Embedding.__new__(gshell.Embedding).carry(np.zeros((3, 3)))

    def test_shell_properties(self):
        V, F = gshell.builtin("sphere:2")
        shell = gshell.generate(V, F, thickness=0.1)
        n, m = len(V), len(F)
        np.testing.assert_array_equal(shell.base, V)
        np.testing.assert_array_equal(shell.faces, F)
        self.assertEqual(shell.top.shape, (n, 3))
        self.assertEqual(shell.vertices.shape, (2 * n, 3))
        np.testing.assert_array_equal(shell.vertices[n:], shell.top)
        self.assertEqual(shell.tets.shape, (3 * m, 4))
        self.assertEqual(shell.tets.dtype, np.int64)
        self.assertEqual(shell.stretch.shape, (3 * m,))
        self.assertEqual(shell.thickness, 0.1)
        # Every tet of a generated sphere shell is positively oriented.
        X = shell.vertices[shell.tets]
        det = np.linalg.det(np.stack([X[:, 1] - X[:, 0], X[:, 2] - X[:, 0], X[:, 3] - X[:, 0]], axis=2))
        self.assertTrue((det > 0).all())
        # A sphere's shell is a thicker sphere: every top vertex sits about eta above the base.
        np.testing.assert_allclose(np.linalg.norm(shell.top, axis=1), 1.1, rtol=2e-2)
        self.assertGreaterEqual(shell.stretch.min(), 0.0)
        np.testing.assert_allclose(shell.stretch.max(), shell.report["stretch"]["max"], rtol=1e-12)
        with self.assertRaises(ValueError):
            shell.top[0, 0] = 5.0  # read-only: the shell's state cannot change behind its back
        self.assertIn("Shell", repr(shell))

    def test_energy_does_not_increase(self):
        V, F = gshell.builtin("bowl:12")
        shell = gshell.generate(V, F, thickness_ratio=0.05, iterations=20, tolerance=0)
        energy = shell.report["energy"]
        self.assertEqual(len(energy), 21)
        self.assertTrue(all(b <= a * (1 + 1e-12) for a, b in zip(energy, energy[1:])))

    def test_shell_from_arrays_and_folder(self):
        out, top, _ = self.cli_shell("builtin:sphere:2", "--thickness", "0.05")
        V, F = gshell.builtin("sphere:2")
        generated = gshell.generate(V, F, thickness=0.05)
        wrapped = gshell.Shell(V, F, top, 0.05)
        loaded = gshell.load_shell(out)
        for s in (wrapped, loaded):
            np.testing.assert_allclose(s.top, generated.top, atol=1e-9)
            np.testing.assert_allclose(s.stretch, generated.stretch, atol=1e-9)
            np.testing.assert_array_equal(s.tets, generated.tets)
            self.assertAlmostEqual(s.thickness, 0.05)
            self.assertIsNone(s.report["certificate"]["top_self_intersections"])
            self.assertIsNone(s.report["valid"])  # pair tests skipped, no tet inverted
            self.assertEqual(s.report["certificate"]["inverted_tets"], 0)

    def test_arguments_of_the_wrong_type_get_one_short_line(self):
        V, F = gshell.builtin("sphere:2")
        shell = gshell.generate(V, F, thickness=0.1)
        calls = {
            "thickness=str": lambda: gshell.generate(V, F, thickness="0.1"),
            "foo=int": lambda: gshell.generate(V, F, thickness=0.1, foo=1),
            "tolerance=str": lambda: gshell.Deformer(shell).solve(V, tolerance="1"),
            "(Shell, ndarray, ndarray, ndarray, str)": lambda: gshell.Shell(V, F, shell.top, "x"),
            "(Deformer, ndarray)": lambda: gshell.Deformer(V),
        }
        for given, call in calls.items():
            with self.subTest(given), self.assertRaises(TypeError) as caught:
                call()
            text = str(caught.exception)
            self.assertNotIn("\n", text)
            self.assertLess(len(text), 600)
            self.assertIn(given, text)
            self.assertNotIn("0.52573111", text)  # no array printed
        # None for a bool parameter is not False (pybind11 alone would take it so), by keyword or position.
        for call, words in ((lambda: gshell.generate(V, F, thickness=0.1, allow_invalid=None), "generate(): allow_invalid"),
                            (lambda: gshell.Deformer(shell, allow_invalid=None), "Deformer(): allow_invalid"),
                            (lambda: gshell.generate(V, F, thickness=0.1, count_intersections=None),
                             "generate(): count_intersections")):
            with self.subTest(words), self.assertRaises(TypeError) as caught:
                call()
            self.assertEqual(str(caught.exception), words + " must be True or False, not None")
        # Nor is a number or a string a flag.
        for value, shown in ((2, "2"), (0, "0"), (1.0, "1.0"), ("yes", "str"), (np.int64(1), "int64")):
            with self.subTest(value=value), self.assertRaises(TypeError) as caught:
                gshell.generate(V, F, thickness=0.1, allow_invalid=value)
            self.assertEqual(str(caught.exception), "generate(): allow_invalid must be True or False, not " + shown)
        gshell.generate(V, F, thickness=0.1, allow_invalid=np.bool_(False))  # numpy's bools are still bools
        # A TypeError raised inside a call (here by the progress callable) passes unchanged.
        def progress(update):
            raise TypeError("mine")
        with self.assertRaisesRegex(TypeError, "^mine$"):
            gshell.generate(V, F, thickness=0.1, progress=progress)

    def test_functions_have_signatures_for_inspect_and_help(self):
        # The wrapper of the line above pointed inspect at pybind11's builtin: signature() raised.
        import inspect
        generate = inspect.signature(gshell.generate).parameters
        self.assertEqual(list(generate)[:3], ["V", "F", "thickness"])
        self.assertEqual(generate["method"].kind, inspect.Parameter.KEYWORD_ONLY)
        self.assertEqual(repr(generate["method"].default), "'rigid'")
        self.assertEqual(list(inspect.signature(gshell.Poser.solve).parameters)[:2], ["self", "handles"])
        self.assertEqual(list(inspect.signature(gshell.Poser.reset).parameters), ["self"])

    def test_bad_arguments_raise_value_error(self):
        V, F = gshell.builtin("sphere:1")
        cases = {
            "both thicknesses": dict(thickness=0.1, thickness_ratio=0.1),
            "no thickness": dict(),
            "zero thickness": dict(thickness=0.0),
            "nan thickness": dict(thickness=float("nan")),
            "negative ratio": dict(thickness_ratio=-1.0),
            "unknown method": dict(thickness=0.1, method="magic"),
            "negative iterations": dict(thickness=0.1, iterations=-1),
            "nan tolerance": dict(thickness=0.1, tolerance=float("nan")),
            "ratio over 10": dict(thickness_ratio=1e20),
            "Anderson history over 100": dict(thickness=0.1, anderson=10**9),
            "thickness under 1e-9 of the mesh": dict(thickness=1e-12),
        }
        for name, kwargs in cases.items():
            with self.subTest(name), self.assertRaises(ValueError):
                gshell.generate(V, F, **kwargs)
        with self.assertRaises(ValueError):  # the metrics' normal prisms alike
            gshell.metrics(V, F, V * 1.1, thickness=1e-300)
        arrays = {
            "int V": (V.astype(int), F),
            "float F": (V, F.astype(float)),
            "V (n,2)": (V[:, :2], F),
            "F (m,4)": (V, np.hstack([F, F[:, :1]])),
            "NaN": (np.where(V > 0.5, np.nan, V), F),
            "index out of range": (V, np.vstack([F, [[0, 1, len(V)]]])),
            "negative index": (V, np.vstack([F, [[0, 1, -1]]])),
            "repeated index": (V, np.vstack([F, [[0, 0, 1]]])),
            "non-manifold": (V, np.vstack([F, F[:1]])),
            "no faces": (V, np.zeros((0, 3), dtype=int)),
            "no vertices": (np.zeros((0, 3)), np.zeros((0, 3), dtype=int)),
        }
        for name, (Vx, Fx) in arrays.items():
            with self.subTest(name), self.assertRaises(ValueError):
                gshell.generate(Vx, Fx, thickness=0.1)
        with self.assertRaises(ValueError):
            gshell.Shell(V, F, V[:-1], 0.1)
        with self.assertRaises(ValueError):
            gshell.Shell(V, F, V * 1.1, -1.0)
        with self.assertRaises(ValueError):
            gshell.load_shell(self.path("no_such_shell"))
        with self.assertRaises(TypeError):  # not an array argument at all: Python's own error
            gshell.generate(V, F, thickness="thick")


class GilTest(unittest.TestCase):
    """Long calls release the GIL. Proven with events, not timing: the call stops at a probe inside
    its GIL-free part and goes on only when this thread has run Python code and let it go. A call
    that held the GIL would keep this thread from running until the probe gave up (60 s), and then
    report that it was not let go."""

    def assert_releases_the_gil(self, work):
        gshell._gil_probe_arm()
        errors = []

        def run():
            try:
                work()
            except Exception as e:  # pragma: no cover - reported below
                errors.append(e)
        worker = threading.Thread(target=run)
        worker.start()
        self.assertTrue(gshell._gil_probe_wait_entered(120), "the call never reached its GIL-free part")
        ran_python = sum(range(1000))  # Python code on this thread while the call is inside
        gshell._gil_probe_release()
        worker.join()
        self.assertEqual(errors, [])
        self.assertEqual(ran_python, 499500)
        self.assertTrue(gshell._gil_probe_passed(), "the call held the GIL")

    def test_long_calls_release_the_gil(self):
        V, F = gshell.builtin("sphere:2")
        self.assert_releases_the_gil(lambda: gshell.generate(V, F, thickness=0.05, iterations=2))
        shell = gshell.generate(V, F, thickness=0.05, iterations=1, count_intersections=False)
        deformer = gshell.Deformer(shell)
        self.assert_releases_the_gil(lambda: deformer.solve(V * 1.1, iterations=2))
        self.assert_releases_the_gil(lambda: gshell.deform(shell, [V * 1.1], iterations=2))
        poser = gshell.Poser(shell, solver="single")
        self.assert_releases_the_gil(lambda: poser.solve(HANDLES, iterations=2))


class MetricsTest(TempDirTest):
    def test_agrees_with_cli(self):
        V, F = gshell.builtin("sphere:3")
        top = V * 1.05 + 0.002 * np.sin(7 * V)  # a bumpy top: non-trivial stretch
        gshell.write_mesh(self.path("top.obj"), top, F)
        run_cli("metrics", "builtin:sphere:3", self.path("top.obj"), "--thickness", "0.05",
                "-o", self.path("m.json"), "--quiet")
        with open(self.path("m.json")) as f:
            cli = json.load(f)
        mine = gshell.metrics(V, F, top, 0.05)
        for key in ("vertices", "faces", "tets", "valid", "certificate", "base_self_intersections",
                    "thinned_vertices"):
            self.assertEqual(mine[key], cli[key], key)
        for group in ("stretch", "thickness"):
            for key, value in cli[group].items():
                if value is None:
                    self.assertIsNone(mine[group][key])
                else:
                    self.assertAlmostEqual(mine[group][key], value, delta=1e-9 * max(1, abs(value)), msg=key)
        self.assertEqual(mine["warnings"], cli["warnings"])
        # Every key of the CLI's file but the two input file names, which arrays do not have.
        self.assertEqual(set(cli) - set(mine), {"base", "top"})
        self.assertEqual(mine["gshell_version"], cli["gshell_version"])
        self.assertEqual(mine["tet_stretch"].shape, (3 * len(F),))
        self.assertEqual(mine["vertex_thickness"].shape, (len(V),))
        self.assertAlmostEqual(mine["vertex_thickness"].min(), cli["thickness"]["min"], delta=1e-9)

    def test_warnings_of_the_base_are_reported(self):
        # A vertex no face uses: `gshell metrics -o` lists it, and so does metrics().
        V, F = gshell.builtin("sphere:2")
        V_extra = np.vstack([V, [[5.0, 5.0, 5.0]]])
        mine = gshell.metrics(V_extra, F, V_extra * 1.05, 0.05)
        self.assertEqual(len(mine["warnings"]), 1)
        self.assertIn("is used by no face", mine["warnings"][0])

    def test_exact_offset_sphere(self):
        # The concentric sphere at distance eta: thickness exactly 1 (relative), no intersections.
        V, F = gshell.builtin("sphere:2")
        m = gshell.metrics(V, F, V * 1.1, thickness=0.1)
        self.assertAlmostEqual(m["thickness"]["min"], 1.0, delta=1e-3)
        self.assertTrue(m["valid"])
        self.assertEqual(m["certificate"], {"inverted_tets": 0, "top_self_intersections": 0,
                                            "top_base_intersections": 0, "wall_intersections": 0,
                                            "nested_parts": 0, "exact": True})
        self.assertEqual(m["base_self_intersections"], 0)
        self.assertEqual(m["thinned_vertices"], 0)
        for old_key in ("inverted_tets", "top_self_intersections", "top_base_intersections"):
            self.assertNotIn(old_key, m)
        m = gshell.metrics(V, F, V * 1.1, thickness_ratio=0.1, count_intersections=False)
        self.assertIsNone(m["certificate"]["top_self_intersections"])
        self.assertIsNone(m["valid"])
        self.assertAlmostEqual(m["thickness"]["ratio"], 0.1)

    def test_bad_arguments(self):
        V, F = gshell.builtin("sphere:1")
        for args, kwargs in [((V, F, V[:-1], 0.1), {}), ((V, F, V, 0.1), dict(thickness_ratio=0.1)),
                             ((V, F, V), {}), ((V, F, np.full_like(V, np.nan), 0.1), {}),
                             ((V, F, V.astype(np.int32), 0.1), {}), ((V, F + 1, V, 0.1), {}),
                             ((V, F, V * 1e200, 0.1), {})]:
            with self.subTest(kwargs=kwargs), self.assertRaises(ValueError):
                gshell.metrics(*args, **kwargs)

    def test_a_shell_from_arrays_is_held_to_what_generation_builds(self):
        V, F = gshell.builtin("sphere:1")
        for top, thickness, says in [(V * 1e200, 0.1, "gshell needs |x| < 1e+50"),
                                     (V * 1.1, 1e300, "gshell builds layers up to 10 times it"),
                                     (V * 1.1, 1e-300, "double precision cannot tell")]:
            with self.subTest(says=says), self.assertRaisesRegex(ValueError, says):
                gshell.Shell(V, F, top, thickness)


class DeformTest(TempDirTest):
    @classmethod
    def setUpClass(cls):
        V, F = gshell.builtin("sphere:3")
        cls.shell = gshell.generate(V, F, thickness=0.05, count_intersections=False)

    def test_rigid_motion_moves_top_rigidly(self):
        d = gshell.Deformer(self.shell)
        self.assertIsNone(d.last)
        R, t = rotation([1, 2, 3], 40), np.array([0.3, -0.2, 0.5])
        top = d.solve(self.shell.base @ R.T + t, tolerance=1e-9)
        np.testing.assert_allclose(top, self.shell.top @ R.T + t, atol=1e-6)
        self.assertLess(d.last["stretch"]["max"], 1e-9)
        self.assertEqual(d.last["inverted_tets"], 0)
        np.testing.assert_allclose(d.vertices[len(top):], top)

    def bend_frames(self, count):
        """A growing bend: from the second frame on each warm start differs (extrapolated uses the
        previous frame's correction, rotated does not), so a wrong default would show."""
        V = self.shell.base
        frames = []
        for k in range(1, count + 1):
            bent = V.copy()
            bent[:, 0] += 0.3 * k / count * V[:, 2] ** 2
            frames.append(bent)
        return frames

    def cli_deform(self, frames, *options):
        out = self.path("shell")
        if not os.path.exists(out):
            run_cli("generate", "builtin:sphere:3", "-o", out, "--thickness", "0.05", "--quiet")
        paths = []
        for k, frame in enumerate(frames):
            paths.append(self.path(f"bent_{k}.obj"))
            gshell.write_mesh(paths[-1], frame, self.shell.faces)
        result = self.path("def_" + str(len(os.listdir(self.tmp))))
        run_cli("deform", "--shell", out, "--base", *paths, "-o", result, "--quiet", *options)
        with open(os.path.join(result, "report.json")) as f:
            return out, result, json.load(f)

    def test_agrees_with_cli(self):
        frames = self.bend_frames(4)
        out, result, cli = self.cli_deform(frames)
        d = gshell.Deformer(gshell.load_shell(out))
        for k, frame in enumerate(frames):
            top = d.solve(frame)
            cli_top, _ = gshell.read_mesh(os.path.join(result, f"frame_{k + 1:04d}", "top.obj"))
            np.testing.assert_allclose(top, cli_top, atol=1e-9)
            record = {key: value for key, value in cli["frames"][k].items() if key not in ("frame", "base")}
            assert_same_report(self, record, d.last, f"frame {k + 1}")
        # The frames after the first tell the warm starts apart: the default is the CLI's.
        rotated = gshell.Deformer(gshell.load_shell(out))
        for frame in frames:
            rotated.solve(frame, warm_start="rotated")
        start = cli["frames"][-1]["energy"][0]
        self.assertGreater(abs(rotated.last["energy"][0] - start), 1e-6 * start)

    def test_deform_report_agrees_with_cli(self):
        frames = self.bend_frames(3)
        out, result, cli = self.cli_deform(frames, "--compare-offset", "--iterations", "30")
        mine_dir = self.path("mine")
        report = gshell.deform(gshell.load_shell(out), frames, output=mine_dir, iterations=30, compare_offset=True)
        self.assertGreater(count_numbers(report), 60)
        assert_same_report(self, cli, report)
        with open(os.path.join(mine_dir, "report.json")) as f:
            self.assertEqual(json.load(f)["summary"], report["summary"])
        for k in range(1, 4):
            mine_top, _ = gshell.read_mesh(os.path.join(mine_dir, f"frame_{k:04d}", "top.obj"))
            cli_top, _ = gshell.read_mesh(os.path.join(result, f"frame_{k:04d}", "top.obj"))
            np.testing.assert_allclose(mine_top, cli_top, atol=1e-9)
        # output is a path like every other: pathlib, and names that are not UTF-8 (os.fsdecode).
        latin1 = os.fsdecode(os.fsencode(self.path("")) + b"lat\xe9")
        for output in (pathlib.Path(self.path("as_path")), latin1):
            gshell.deform(gshell.load_shell(out), frames[:1], output=output, iterations=5)
            self.assertTrue(os.path.exists(os.path.join(output, "frame_0001", "top.obj")), output)

    def test_reset_and_threads(self):
        d = gshell.Deformer(self.shell)
        R = rotation([0, 0, 1], 30)
        first = d.solve(self.shell.base @ R.T)
        d.reset()
        np.testing.assert_allclose(d.solve(self.shell.base @ R.T), first, atol=1e-12)
        # Concurrent solves on one deformer take turns (the GIL is released inside).
        results, errors = [], []

        def work(k):
            try:
                results.append(d.solve(self.shell.base @ rotation([0, 1, 0], 5 * k).T, tolerance=1e-8))
            except Exception as e:  # pragma: no cover - reported below
                errors.append(e)
        threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        self.assertEqual(errors, [])
        self.assertEqual(len(results), 4)

    def test_bad_arguments(self):
        d = gshell.Deformer(self.shell)
        V = self.shell.base
        for args, kwargs in [((V[:-1],), {}), ((np.where(V > 0.9, np.nan, V),), {}), ((V.astype(int),), {}),
                             ((V,), dict(warm_start="sideways")), ((V,), dict(iterations=-2)),
                             ((V,), dict(tolerance=-1.0))]:
            with self.subTest(kwargs=kwargs), self.assertRaises(ValueError):
                d.solve(*args, **kwargs)
        with self.assertRaises(TypeError):
            gshell.Deformer("not a shell")
        # Frames beyond the limits are named by their argument, the same in Deformer and deform.
        for scale, problem in ((1e60, "has a coordinate of magnitude"), (1e-45, "the mesh is too small"),
                               (0.0, "every vertex is at one point"),
                               (1e-3, "the frame is 0.001 times the size of the rest shell's base"),
                               (1e3, "the frame is 1000 times the size of the rest shell's base")):
            with self.subTest(scale=scale):
                with self.assertRaisesRegex(ValueError, "^new_base: .*" + problem):
                    d.solve(V * scale)
                with self.assertRaisesRegex(ValueError, r"^frames\[1\]: .*" + problem):
                    gshell.deform(self.shell, [V, V * scale])


class EmbedTest(TempDirTest):
    @classmethod
    def setUpClass(cls):
        V, F = gshell.builtin("sphere:2")
        cls.shell = gshell.generate(V, F, thickness=0.1, count_intersections=False)

    def test_carry_reproduces_rest_and_follows_rigid_motion(self):
        X = self.shell.vertices
        points = X[self.shell.tets].mean(axis=1)  # tet centroids: inside by construction
        e = gshell.embed(self.shell, points)
        self.assertEqual(len(e), len(points))
        self.assertEqual(len(e.outside), 0)
        np.testing.assert_allclose(e.bary.sum(axis=1), 1.0, atol=1e-12)
        np.testing.assert_allclose(e.carry(self.shell), points, atol=1e-12)
        np.testing.assert_allclose(e.carry(X), points, atol=1e-12)
        R, t = rotation([1, 1, 0], 70), np.array([1.0, 2.0, 3.0])
        np.testing.assert_allclose(e.carry(X @ R.T + t), points @ R.T + t, atol=1e-12)
        d = gshell.Deformer(self.shell)
        d.solve(self.shell.base @ R.T + t, tolerance=1e-10)
        np.testing.assert_allclose(e.carry(d.vertices), points @ R.T + t, atol=1e-6)

    def test_outside_points(self):
        e = gshell.embed(self.shell, np.array([[0.0, 0.0, 2.0], [0.0, 0.0, 1.05]]))
        np.testing.assert_array_equal(e.outside, [0])
        self.assertGreater(e.max_outside_distance, 0.5)
        np.testing.assert_allclose(e.carry(self.shell), [[0, 0, 2], [0, 0, 1.05]], atol=1e-9)

    def test_embeddings_pickle_as_they_are(self):
        # Workers of multiprocessing carry detail with an embedding made once: the copy carries
        # bit for bit as the original, outside points included; a state changed by hand is refused.
        points = np.vstack([self.shell.vertices[self.shell.tets].mean(axis=1)[:50], [[0.0, 0.0, 2.0]]])
        e = gshell.embed(self.shell, points)
        copy = pickle.loads(pickle.dumps(e))
        for name in ("tet", "tet_vertices", "bary", "outside"):
            np.testing.assert_array_equal(getattr(copy, name), getattr(e, name), err_msg=name)
        self.assertEqual(copy.max_outside_distance, e.max_outside_distance)
        moved = self.shell.vertices * 1.1 + 0.3
        np.testing.assert_array_equal(copy.carry(moved), e.carry(moved))
        with self.assertRaises(ValueError):
            copy.carry(self.shell.vertices[:-1])  # still knows its shell's size
        for index, value, words in ((3, e.tet_vertices + len(self.shell.vertices), "tet vertices"),
                                    (4, e.bary * 2, "do not sum to 1"),
                                    (5, np.array([len(points)]), "outside"),
                                    (0, 99, "not the state of a pickled gshell.Embedding")):
            state = list(e.__getstate__())
            state[index] = value
            with self.subTest(words), self.assertRaisesRegex(ValueError, words):
                gshell.Embedding.__new__(gshell.Embedding).__setstate__(tuple(state))

    def test_agrees_with_cli(self):
        out = self.path("shell")
        run_cli("generate", "builtin:sphere:2", "-o", out, "--thickness", "0.1", "--quiet")
        detail = gshell.builtin("sphere:1")
        dV = detail[0] * 1.05
        gshell.write_mesh(self.path("detail.obj"), dV, detail[1])
        R = rotation([0, 1, 1], 25)
        gshell.write_mesh(self.path("moved.obj"), self.shell.base @ R.T, self.shell.faces)
        run_cli("deform", "--shell", out, "--base", self.path("moved.obj"), "--embed", self.path("detail.obj"),
                "-o", self.path("def"), "--quiet")
        cli_detail, _ = gshell.read_mesh(os.path.join(self.path("def"), "frame_0001", "detail.obj"))
        shell = gshell.load_shell(out)
        d = gshell.Deformer(shell)
        d.solve(shell.base @ R.T)
        np.testing.assert_allclose(gshell.embed(shell, dV).carry(d.vertices), cli_detail, atol=1e-9)

    def test_bad_arguments(self):
        with self.assertRaises(ValueError):
            gshell.embed(self.shell, np.array([[np.nan, 0, 0]]))
        with self.assertRaises(ValueError):
            gshell.embed(self.shell, np.zeros((3, 2)))
        with self.assertRaisesRegex(ValueError, "^points: vertex 0 has a coordinate of magnitude 1e\\+60"):
            gshell.embed(self.shell, np.array([[1e60, 0, 0]]))
        e = gshell.embed(self.shell, np.zeros((1, 3)))
        with self.assertRaisesRegex(ValueError, "^shell vertices: vertex 0 has a coordinate of magnitude "):
            e.carry(self.shell.vertices * 1e60)
        with self.assertRaises(ValueError):
            e.carry(self.shell.vertices[:-1])
        with self.assertRaises(ValueError):
            e.carry(gshell.generate(*gshell.builtin("sphere:1"), thickness=0.1))


HANDLES = {"handles": [
    {"select": {"surface": "both", "box": [-2, -2, -2, 2, 2, -0.7]}},
    {"select": {"surface": "both", "box": [-2, -2, 0.7, 2, 2, 2]}, "translate": [0.2, 0, 0.1],
     "rotate": {"axis": [0, 1, 0], "degrees": 30}},
]}


class TextureCoordinatesTest(TempDirTest):
    def test_folders_written_from_a_loaded_shell_keep_its_uvs(self):
        # Poser.write and deform(output=) wrote base.obj / top.obj without the base's `vt`, so
        # `gshell texture` refused the folders the CLI's pose and deform would have written.
        out = self.path("plane")
        run_cli("generate", "builtin:plane:8", "-o", out, "--thickness", "0.1", "--quiet")
        shell = gshell.load_shell(out)
        lift = {"handles": [{"select": {"surface": "both", "box": [-2, -2, -1, -0.5, 2, 1]}},
                            {"select": {"surface": "both", "box": [0.5, -2, -1, 2, 2, 1]}, "translate": [0, 0, 0.3]}]}

        def vt_lines(path):
            with open(path) as f:
                return [line for line in f if line.startswith("vt ")]

        expected = vt_lines(os.path.join(out, "base.obj"))
        self.assertEqual(len(expected), 81)
        for copy in (shell, pickle.loads(pickle.dumps(shell))):
            posed = self.path("posed")
            shutil.rmtree(posed, ignore_errors=True)
            poser = gshell.Poser(copy, solver="single")
            poser.solve(lift, iterations=20, steps=1)
            poser.write(posed)
            for name in ("base.obj", "top.obj"):
                self.assertEqual(vt_lines(os.path.join(posed, name)), expected, name)
            run_cli("texture", "--shell", posed, "--tile", "builtin:bumps:4", "-o", self.path("tiled.obj"), "--quiet")
        V, _ = gshell.read_mesh(os.path.join(out, "base.obj"))
        frames = self.path("frames")
        gshell.deform(shell, [V + [0, 0, 0.2]], output=frames, iterations=5)
        self.assertEqual(vt_lines(os.path.join(frames, "frame_0001", "top.obj")), expected)
        # A shell made from arrays has none to keep.
        made = gshell.Shell(shell.base, shell.faces, shell.top, shell.thickness)
        self.assertEqual(pickle.loads(pickle.dumps(made)).faces.shape, shell.faces.shape)


class PoseTest(TempDirTest):
    @classmethod
    def setUpClass(cls):
        V, F = gshell.builtin("sphere:2")
        cls.shell = gshell.generate(V, F, thickness=0.05, count_intersections=False)

    def test_agrees_with_cli(self):
        out = self.path("shell")
        run_cli("generate", "builtin:sphere:2", "-o", out, "--thickness", "0.05", "--quiet")
        handles = self.path("handles.json")
        with open(handles, "w") as f:
            json.dump(HANDLES, f)
        shell = gshell.load_shell(out)
        for solver in ("hierarchical", "single"):
            with self.subTest(solver=solver):
                levels = ["--levels", "3"] if solver == "hierarchical" else []  # an error with single
                run_cli("pose", "--shell", out, "--handles", handles, "-o", self.path("posed"), "--solver", solver,
                        *levels, "--iterations", "20", "--steps", "2", "--quiet")
                shutil.rmtree(self.path("py_posed"), ignore_errors=True)
                cli_base, _ = gshell.read_mesh(os.path.join(self.path("posed"), "base.obj"))
                cli_top, _ = gshell.read_mesh(os.path.join(self.path("posed"), "top.obj"))
                with open(os.path.join(self.path("posed"), "report.json")) as f:
                    cli = json.load(f)
                levels = {"levels": 3} if solver == "hierarchical" else {}
                poser = gshell.Poser(shell, solver=solver, **levels)
                base, top = poser.solve(HANDLES, iterations=20, steps=2)
                np.testing.assert_allclose(base, cli_base, atol=1e-9)
                np.testing.assert_allclose(top, cli_top, atol=1e-9)
                last = poser.last
                self.assertGreater(count_numbers(last), 15)
                assert_same_report(self, cli, last)
                self.assertEqual([s["fraction"] for s in last["steps"]], [0.5, 1.0])
                # The posed folder Poser writes is the CLI's.
                poser.write(self.path("py_posed"))
                with open(os.path.join(self.path("py_posed"), "report.json")) as f:
                    assert_same_report(self, cli, json.load(f))
                py_top, _ = gshell.read_mesh(os.path.join(self.path("py_posed"), "top.obj"))
                np.testing.assert_allclose(py_top, cli_top, atol=1e-9)
                # Nor does it replace the folder its rest shell was loaded from (it did; the CLI refuses).
                self.assertEqual(last["shell"], out)
                with self.assertRaisesRegex(ValueError, "is the folder of the rest shell being posed"):
                    poser.write(out)
                # The same handles from the file, and as JSON text, give the same result.
                with open(handles) as f:
                    text = "\n  " + f.read()
                for source in (handles, text):
                    named = gshell.Poser(shell, solver=solver, **levels)
                    base2, top2 = named.solve(source, iterations=20, steps=2)
                    np.testing.assert_array_equal(base2, base)
                    np.testing.assert_array_equal(top2, top)
                    # A handle file is named in the report as the CLI names it; JSON text is not.
                    self.assertEqual(named.last["handles"], handles if source == handles else "")
                self.assertEqual(cli["handles"], handles)

    def test_rigid_handle_moves_everything_rigidly(self):
        everything = {"handles": [{"select": {"box": [-5, -5, -5, 5, 5, 5]}, "translate": [1, 2, 3],
                                   "rotate": {"axis": [1, 0, 0], "degrees": 90, "center": [0, 0, 0]}}]}
        poser = gshell.Poser(self.shell, solver="single")
        base, top = poser.solve(everything)
        R = rotation([1, 0, 0], 90)
        np.testing.assert_allclose(base, self.shell.base @ R.T + [1, 2, 3], atol=1e-12)
        np.testing.assert_allclose(top, self.shell.top @ R.T + [1, 2, 3], atol=1e-12)
        self.assertLess(poser.last["stretch"]["max"], 1e-20)

    def test_held_handles_keep_the_rest_shell(self):
        held = {"handles": [{"select": {"box": [-5, -5, -5, 5, 5, -0.5]}}]}
        poser = gshell.Poser(self.shell, levels=3)
        self.assertIsNone(poser.last)
        np.testing.assert_array_equal(poser.vertices, self.shell.vertices)
        base, top = poser.solve(held, iterations=5)
        np.testing.assert_allclose(base, self.shell.base, atol=1e-9)
        np.testing.assert_allclose(top, self.shell.top, atol=1e-9)
        self.assertEqual(poser.last["inverted_tets"], 0)

    def test_reset_solves_as_a_fresh_poser(self):
        # Bit for bit, over several steps: after reset() the next drag continues along the handles'
        # motion as a fresh Poser's does (it used to take the targets' last change, landing 1e-5
        # away, within the solve's tolerance).
        for solver in ("single", "hierarchical"):
            with self.subTest(solver=solver):
                poser = gshell.Poser(self.shell, solver=solver)
                poser.solve(HANDLES, steps=3)
                poser.reset()
                base, top = poser.solve(HANDLES, steps=3)
                fresh_base, fresh_top = gshell.Poser(self.shell, solver=solver).solve(HANDLES, steps=3)
                np.testing.assert_array_equal(base, fresh_base)
                np.testing.assert_array_equal(top, fresh_top)

    def test_drag_continues_with_the_same_handles(self):
        poser = gshell.Poser(self.shell, solver="single")
        poser.solve(HANDLES, fraction=0.5)
        self.assertEqual(poser.last["steps"][0]["fraction"], 0.5)
        poser.solve(HANDLES, steps=2)
        self.assertEqual([s["fraction"] for s in poser.last["steps"]], [0.75, 1.0])
        poser.reset()
        poser.solve(HANDLES, steps=2)
        self.assertEqual([s["fraction"] for s in poser.last["steps"]], [0.5, 1.0])

    def test_bad_arguments(self):
        poser = gshell.Poser(self.shell, solver="single")
        # A path with a NUL byte, or whose __fspath__ raises: that error, not "Unable to cast".
        with self.assertRaisesRegex(ValueError, "NUL byte"):
            poser.solve("handles.json\0x")

        class BrokenPath:
            def __fspath__(self):
                raise ZeroDivisionError("mine")
        with self.assertRaisesRegex(ZeroDivisionError, "mine"):
            poser.solve(BrokenPath())
        # JSON text read from a BOM-marked file keeps the mark; it is still JSON text, not a file name.
        poser.solve("\ufeff" + json.dumps(HANDLES), steps=1)
        self.assertIn("thickness 0.05>", repr(gshell.Shell(*gshell.builtin("sphere:1"), gshell.builtin("sphere:1")[0] * 1.05, 0.05)))
        bad_handles = {
            "unknown key": {"handles": [{"vertices": [0], "pull": [0, 0, 1]}]},
            "id out of range": {"handles": [{"vertices": [0, 10**6]}]},
            "empty selection": {"handles": [{"select": {"box": [5, 5, 5, 6, 6, 6]}}]},
            "NaN": {"handles": [{"vertices": [0], "translate": [float("nan"), 0, 0]}]},
            "zero axis": {"handles": [{"vertices": [0], "rotate": {"axis": [0, 0, 0], "degrees": 5}}]},
            "no handles": {"handles": []},
            "not JSON": {"handles": [{"vertices": {1, 2}}]},
        }
        for name, handles in bad_handles.items():
            with self.subTest(name), self.assertRaises(ValueError):
                poser.solve(handles)
        for handles in ([1, 2], 3.5, self.path("missing.json")):
            with self.subTest(handles=handles), self.assertRaises(ValueError):
                poser.solve(handles)
        # JSON text is read as handles, not as a file name: its error is the parser's.
        with self.assertRaisesRegex(ValueError, "^handles argument: handle 0: ") as caught:
            poser.solve('{"handles": [{"vertices": [0], "pull": [0, 0, 1]}]}')
        self.assertNotIn("cannot open", str(caught.exception))
        # The argument and the file format's key are told apart (it read "handles: handles: is empty").
        with self.assertRaisesRegex(ValueError, "^handles argument: handles: is empty"):
            poser.solve({"handles": []})
        for kwargs in (dict(fraction=1.5), dict(steps=0), dict(iterations=0), dict(tolerance=float("nan"))):
            with self.subTest(kwargs=kwargs), self.assertRaises(ValueError):
                poser.solve(HANDLES, **kwargs)
        with self.assertRaises(ValueError):
            gshell.Poser(self.shell, solver="multigrid")
        with self.assertRaises(ValueError):
            gshell.Poser(self.shell, levels=0)
        # As `gshell pose --solver single --levels 3`: refused, not ignored.
        with self.assertRaisesRegex(ValueError, "^levels applies only to solver='hierarchical'$"):
            gshell.Poser(self.shell, solver="single", levels=3)
        # A count past C++ int's range is one line naming the argument (it was pybind11's
        # "incompatible function arguments" TypeError listing the whole signature).
        for call, name in ((lambda: gshell.Poser(self.shell, levels=2**40), "levels"),
                           (lambda: poser.solve(HANDLES, steps=2**31), "steps"),
                           (lambda: poser.solve(HANDLES, iterations=-2**70), "iterations"),
                           (lambda: gshell.generate(self.shell.base, self.shell.faces, thickness=0.1, anderson=2**40),
                            "anderson"),
                           (lambda: gshell.Deformer(self.shell).solve(self.shell.base, iterations=2**40), "iterations")):
            with self.subTest(name=name), self.assertRaisesRegex(ValueError, "^" + name + " is out of range \\(got -?[0-9]+; "
                                                                             "at most 2147483647"):
                call()
        poser.solve(HANDLES, steps=np.int64(1), iterations=np.int32(2))  # NumPy integers are counts too
        # What JSON cannot write is one line naming the argument, not a traceback.
        with self.assertRaisesRegex(ValueError, "^handles cannot be written as JSON: Object of type object is not "
                                                "JSON serializable$"):
            poser.solve({"handles": [{"vertices": [0], "translate": object()}]})

    def test_numpy_ids_and_vectors_in_handles(self):
        # Ids and vectors held in NumPy (np.int64, arrays) are taken as the lists they hold.
        top = np.flatnonzero(self.shell.base[:, 2] > 0.7)
        bottom = np.flatnonzero(self.shell.base[:, 2] < -0.7)
        as_numpy = {"handles": [{"vertices": bottom}, {"vertices": top, "translate": np.array([0.0, 0.0, 0.1])},
                                {"vertices": [np.int64(0)]}]}
        as_lists = {"handles": [{"vertices": bottom.tolist()}, {"vertices": top.tolist(), "translate": [0.0, 0.0, 0.1]},
                                {"vertices": [0]}]}
        base, top_surface = gshell.Poser(self.shell, solver="single").solve(as_numpy, iterations=5)
        expected_base, expected_top = gshell.Poser(self.shell, solver="single").solve(as_lists, iterations=5)
        np.testing.assert_array_equal(base, expected_base)
        np.testing.assert_array_equal(top_surface, expected_top)
        with self.assertRaisesRegex(ValueError, "^handles cannot be written as JSON: Out of range float values"):
            gshell.Poser(self.shell).solve({"handles": [{"vertices": [0], "translate": np.array([np.nan, 0, 0])}]})


def smoothstep(k, count):
    t = k / count
    return t * t * (3 - 2 * t)


def bend_plane(V, degrees, band):
    """The z = 0 plane over [-1, 1]^2 folded about the y axis as gshell's synthetic bend does: the
    middle `band` of x becomes an arc (radius band * 2 / angle) curling towards +z, the rest
    continues along its end tangents (an isometry of the plane)."""
    angle = math.radians(degrees)
    half_band, R = band, 2 * band / angle
    along, across = V[:, 0], V[:, 2]
    clamped = np.clip(along, -half_band, half_band)
    beyond, phi = along - clamped, clamped / R
    out = V.copy()
    out[:, 0] = (R - across) * np.sin(phi) + beyond * np.cos(phi)
    out[:, 2] = R - (R - across) * np.cos(phi) + beyond * np.sin(phi)
    return out


FRAME_FIELDS = {"valid", "method", "resumed", "fresh_top", "substeps", "guarded_iterations", "thinned_vertices",
                "certificate", "base_self_intersections", "unextrudable_vertices"}


class DeformGuardTest(TempDirTest):
    """Deformer(allow_invalid=) and deform(allow_invalid=): valid frames by default, the unguarded
    ones with allow_invalid=True. A plane shell of thickness 0.3 bent to 150 degrees in a band of
    radius 0.15: the paper's frames invert tets there."""

    @classmethod
    def setUpClass(cls):
        V, F = gshell.builtin("plane:16")
        cls.eta = 0.3
        cls.shell = gshell.generate(V, F, thickness=cls.eta, count_intersections=False)
        cls.frames = [bend_plane(V, 150 * smoothstep(k, 6), 0.2) for k in range(1, 7)]

    def certify(self, base, top):
        """The frame certified independently of the deformer's report."""
        return gshell.metrics(base, self.shell.faces, top, thickness=self.eta)

    def test_frames_are_valid_by_default(self):
        d = gshell.Deformer(self.shell)
        methods = []
        for k, frame in enumerate(self.frames):
            top = d.solve(frame)
            last = d.last
            self.assertLessEqual(FRAME_FIELDS, set(last), f"frame {k + 1}")
            self.assertTrue(last["valid"], f"frame {k + 1}")
            self.assertEqual(last["certificate"]["inverted_tets"], 0)
            methods.append(last["method"])
            m = self.certify(frame, top)
            self.assertTrue(m["valid"], f"frame {k + 1}")
            self.assertEqual(m["certificate"]["inverted_tets"], 0)
            self.assertEqual(m["base_self_intersections"], 0)
        # far frames the paper's solve got wrong are mended in place, near ones dragged
        self.assertLessEqual(set(methods), {"bounded", "guarded", "mended"})
        self.assertIn("mended", methods)  # the guard had to act

    def test_allow_invalid_reproduces_the_unguarded_frames(self):
        guarded, loose = gshell.Deformer(self.shell), gshell.Deformer(self.shell, allow_invalid=True)
        invalid, same_so_far = 0, True
        for k, frame in enumerate(self.frames):
            top_g, top_u = guarded.solve(frame), loose.solve(frame)
            self.assertEqual(loose.last["method"], "unguarded")
            self.assertEqual(loose.last["substeps"], 0)
            self.assertLessEqual(FRAME_FIELDS, set(loose.last))
            # A frame the guard took as solved ("bounded") is the paper's frame, bit for bit, as
            # long as the frames before it were too.
            same_so_far = same_so_far and guarded.last["method"] == "bounded"
            if same_so_far:
                np.testing.assert_array_equal(top_g, top_u, f"frame {k + 1}")
            m = self.certify(frame, top_u)
            self.assertEqual(loose.last["valid"], m["valid"], f"frame {k + 1}")
            invalid += 0 if m["valid"] else 1
        self.assertGreater(invalid, 0)  # the paper's frames break validity here
        self.assertFalse(same_so_far)   # and the guarded ones differ from some frame on

    def test_deform_reports_per_frame_and_summary(self):
        report = gshell.deform(self.shell, self.frames)
        loose = gshell.deform(self.shell, self.frames, allow_invalid=True)
        for r in (report, loose):
            for key in ("valid_frames", "invalid_frames", "certificate_inverted_tets", "guarded_frames",
                        "max_substeps"):
                self.assertIn(key, r["summary"])
            for f in r["frames"]:
                self.assertLessEqual(FRAME_FIELDS, set(f))
        self.assertEqual(report["summary"]["valid_frames"], len(self.frames))
        self.assertEqual(report["summary"]["certificate_inverted_tets"], 0)
        self.assertGreater(report["summary"]["guarded_frames"], 0)
        self.assertGreater(loose["summary"]["invalid_frames"], 0)
        self.assertGreater(loose["summary"]["certificate_inverted_tets"], 0)
        self.assertEqual(loose["summary"]["guarded_frames"], 0)
        # The invalid frames are named in the report's warnings (the CLI prints them), by cause.
        self.assertEqual(report["warnings"], [])
        self.assertEqual(len(loose["warnings"]), 1)
        self.assertIn("unguarded (allow_invalid)", loose["warnings"][0])
        # deform(allow_invalid=True) is the unguarded Deformer frame by frame.
        d = gshell.Deformer(self.shell, allow_invalid=True)
        for frame, record in zip(self.frames, loose["frames"]):
            d.solve(frame)
            self.assertEqual(d.last["energy"], record["energy"])
            self.assertEqual(d.last["valid"], record["valid"])


class PoseGuardTest(TempDirTest):
    """Poser(allow_invalid=): two handles at opposite sides of a bowl's rim driven through each
    other. Guarded (default) every step is valid and the drag stops at contact; unguarded the shell
    passes through itself."""

    SQUEEZE = {"handles": [
        {"select": {"box": [0.8, -9, -9, 9, 9, 9]}, "translate": [-2.4, 0, 0]},
        {"select": {"box": [-9, -9, -9, -0.8, 9, 9]}, "translate": [2.4, 0, 0]}]}

    @classmethod
    def setUpClass(cls):
        V, F = gshell.builtin("bowl:8")
        cls.shell = gshell.generate(V, F, thickness=0.08, count_intersections=False)

    def squeeze(self, solver, allow_invalid):
        poser = gshell.Poser(self.shell, solver=solver, allow_invalid=allow_invalid)
        base, top = poser.solve(self.SQUEEZE, steps=4, iterations=100, tolerance=1e-5)
        return poser.last, gshell.metrics(base, self.shell.faces, top, thickness=0.08)

    def test_squeeze_stops_at_contact_valid_and_allow_invalid_passes_through(self):
        for solver in ("single", "hierarchical"):
            with self.subTest(solver=solver):
                last, m = self.squeeze(solver, False)
                for step in last["steps"]:
                    for key in ("valid", "method", "blocked_by_contact", "guarded_iterations", "certificate"):
                        self.assertIn(key, step)
                    self.assertTrue(step["valid"], step)
                    self.assertEqual(step["certificate"], {"inverted_tets": 0, "top_self_intersections": 0,
                                                           "top_base_intersections": 0, "wall_intersections": 0,
                                                           "intersections": 0, "nested_parts": 0})
                self.assertTrue(any(step["blocked_by_contact"] for step in last["steps"]))
                self.assertTrue(m["valid"])
                self.assertEqual(m["base_self_intersections"], 0)
                last, m = self.squeeze(solver, True)
                # Unguarded steps are certified too (the report said nothing of them), and agree
                # with metrics().
                step = last["steps"][-1]
                self.assertEqual((step["valid"], step["method"]), (False, "unguarded"))
                self.assertNotIn("blocked_by_contact", step)
                self.assertEqual(step["certificate"]["inverted_tets"], m["certificate"]["inverted_tets"])
                for kind in ("top_self_intersections", "top_base_intersections", "wall_intersections"):
                    self.assertEqual(step["certificate"][kind], m["certificate"][kind])
                self.assertFalse(m["valid"] and m["base_self_intersections"] == 0)
                self.assertIn("unguarded (allow_invalid)", " ".join(last["warnings"]))



class ProgressTest(TempDirTest):
    """progress= on the long calls: every iteration (or frame) reported, results unchanged, and
    Ctrl-C or an exception from the callable ends the call there, leaving nothing behind."""

    @classmethod
    def setUpClass(cls):
        cls.V, cls.F = gshell.builtin("sphere:3")
        cls.shell = gshell.generate(cls.V, cls.F, thickness=0.05, count_intersections=False)

    def test_generate_reports_every_iteration_and_gives_the_same_shell(self):
        V, F = gshell.builtin("torus")
        updates = []
        with_progress = gshell.generate(V, F, thickness=1.3, progress=updates.append)
        plain = gshell.generate(V, F, thickness=1.3)
        np.testing.assert_array_equal(with_progress.top, plain.top)
        paper = [u for u in updates if u["stage"] == "paper"]
        self.assertEqual(updates[:len(paper)], paper)  # the paper's solve comes first
        self.assertEqual([u["iteration"] for u in paper], list(range(1, plain.report["iterations"] + 1)))
        energies = [u["energy"] for u in paper]
        self.assertEqual(energies, sorted(energies, reverse=True))  # the energy never rises
        for u in updates:
            self.assertEqual(set(u), {"stage", "iteration", "energy", "seconds"})
        # Unguarded, the same keys: the paper's iterations are all there is (the Blender add-on
        # read update["stage"] and failed on every Generate with "allow invalid").
        unguarded = []
        gshell.generate(V, F, thickness=1.3, allow_invalid=True, progress=unguarded.append)
        self.assertTrue(unguarded)
        for u in unguarded:
            self.assertEqual(set(u), {"stage", "iteration", "energy", "seconds"})
            self.assertEqual(u["stage"], "paper")

    def test_progress_true_prints_one_line_per_update(self):
        import contextlib
        import io
        lines = io.StringIO()
        with contextlib.redirect_stderr(lines):
            gshell.generate(self.V, self.F, thickness=0.05, iterations=3, tolerance=0, anderson=0, progress=True)
        printed = lines.getvalue().splitlines()
        # Each phase as it begins (those without iterations run for tens of seconds at millions
        # of faces), and each iteration.
        stages = [line for line in printed if "iteration" not in line]
        self.assertEqual(stages, ["gshell.generate: stage " + name for name in
                                  ("setup", "factor", "paper", "start", "metrics", "certificate")])
        iterations = [line for line in printed if "iteration" in line]
        self.assertEqual(len(iterations), 3, printed)
        self.assertTrue(iterations[2].startswith("gshell.generate: stage paper, iteration 3, energy "), printed)
        # No stderr at all (pythonw, some services): nothing printed, as print() does, and the call ends normally.
        with contextlib.redirect_stderr(None):
            shell = gshell.generate(self.V, self.F, thickness=0.05, iterations=3, progress=True)
        self.assertEqual(shell.top.shape, self.V.shape)

    def test_an_exception_from_the_callable_ends_the_call_at_once(self):
        class Stop(Exception):
            pass
        calls = []

        def stop_at_third(update):
            calls.append(update)
            if len(calls) == 3:
                raise Stop()
        with self.assertRaises(Stop):
            gshell.generate(self.V, self.F, thickness=0.05, iterations=20, tolerance=0, anderson=0, progress=stop_at_third)
        self.assertEqual(len(calls), 3)
        # A TypeError too passes unchanged, even one with pybind11's words in it (it was rewritten as
        # if generate's own arguments did not match).
        def type_error(update):
            raise TypeError("f(): incompatible function arguments: mine")
        with self.assertRaises(TypeError) as caught:
            gshell.generate(self.V, self.F, thickness=0.05, progress=type_error)
        self.assertEqual(str(caught.exception), "f(): incompatible function arguments: mine")

    def test_ctrl_c_ends_generate_deform_and_pose_where_they_are(self):
        import _thread

        def interrupt_at(k, calls):
            def callback(update):
                calls.append(update)
                if len(calls) == k:
                    _thread.interrupt_main()  # as Ctrl-C does
            return callback
        calls = []
        with self.assertRaises(KeyboardInterrupt):
            gshell.generate(self.V, self.F, thickness=0.05, iterations=20, tolerance=0, anderson=0,
                            progress=interrupt_at(2, calls))
        self.assertEqual(len(calls), 2)

        # deform: no output folder, no staging folder beside it.
        out = self.path("out")
        calls = []
        with self.assertRaises(KeyboardInterrupt):
            gshell.deform(self.shell, [self.V * 1.1, self.V] * 4, output=out, progress=interrupt_at(3, calls))
        self.assertEqual([u["frame"] for u in calls], [0, 1, 2])
        self.assertEqual(os.listdir(self.tmp), [])

        # Poser: interrupted, it is back at the rest shell (as after reset()) and solves again.
        poser = gshell.Poser(self.shell, solver="single")
        calls = []
        with self.assertRaises(KeyboardInterrupt):
            poser.solve(HANDLES, steps=2, progress=interrupt_at(4, calls))
        self.assertEqual(len(calls), 4)
        self.assertIsNone(poser.last)
        np.testing.assert_array_equal(poser.vertices, np.vstack([self.shell.base, self.shell.top]))
        base, top = poser.solve(HANDLES, steps=2)
        fresh_base, fresh_top = gshell.Poser(self.shell, solver="single").solve(HANDLES, steps=2)
        np.testing.assert_array_equal(base, fresh_base)
        np.testing.assert_array_equal(top, fresh_top)

    def test_embed_reports_each_block_and_ends_on_ctrl_c(self):
        import _thread
        rng = np.random.default_rng(3)
        points = self.shell.base[rng.integers(0, len(self.shell.base), 150000)] * 1.01
        updates = []
        embedded = gshell.embed(self.shell, points, progress=updates.append)
        self.assertEqual([u["located"] for u in updates], [65536, 131072, 150000])
        self.assertTrue(all(u["points"] == 150000 for u in updates))
        np.testing.assert_array_equal(embedded.bary, gshell.embed(self.shell, points).bary)
        calls = []

        def interrupt_at_first(update):
            calls.append(update)
            _thread.interrupt_main()  # as Ctrl-C does
        with self.assertRaises(KeyboardInterrupt):
            gshell.embed(self.shell, points, progress=interrupt_at_first)
        self.assertEqual(len(calls), 1)

    def test_ctrl_c_ends_a_call_without_progress(self):
        # A thread presses Ctrl-C once the deform has written a frame into its staging folder; the
        # call must end there: no output folder, nothing left beside it. (A call that ignored the
        # signal would finish and move its folder into place before the interrupt was raised.)
        import _thread
        out = self.path("out")
        done = threading.Event()

        def press_ctrl_c_when_a_frame_is_written():
            while not done.is_set():
                staging = [n for n in os.listdir(self.tmp) if n.startswith(".out.tmp-")]
                if staging and os.path.exists(os.path.join(self.tmp, staging[0], "frame_0001", "top.obj")):
                    _thread.interrupt_main()
                    return
                done.wait(0.001)
        watcher = threading.Thread(target=press_ctrl_c_when_a_frame_is_written)
        watcher.start()
        try:
            with self.assertRaises(KeyboardInterrupt):
                gshell.deform(self.shell, [self.V * 1.1, self.V] * 500, output=out)
        finally:
            done.set()
            watcher.join()
        self.assertEqual(os.listdir(self.tmp), [])

    def test_deformer_reports_every_iteration_and_ctrl_c_ends_its_frame(self):
        import _thread
        new_base = self.V * np.array([1.3, 1.0, 0.8])
        plain = gshell.Deformer(self.shell, allow_invalid=True).solve(new_base)
        deformer = gshell.Deformer(self.shell, allow_invalid=True)
        updates = []
        top = deformer.solve(new_base, progress=updates.append)
        np.testing.assert_array_equal(top, plain)
        self.assertEqual([u["iteration"] for u in updates], list(range(1, deformer.last["iterations"] + 1)))
        self.assertEqual([u["energy"] for u in updates], deformer.last["energy"][1:])

        guarded = gshell.Deformer(self.shell)
        calls = []

        def interrupt_at_second(update):
            calls.append(update)
            if len(calls) == 2:
                _thread.interrupt_main()
        with self.assertRaises(KeyboardInterrupt):
            guarded.solve(new_base, progress=interrupt_at_second)
        self.assertEqual(len(calls), 2)
        self.assertIsNone(guarded.last)  # back at the rest shell, as after reset()
        np.testing.assert_array_equal(guarded.vertices, np.vstack([self.shell.base, self.shell.top]))
        np.testing.assert_array_equal(guarded.solve(new_base), gshell.Deformer(self.shell).solve(new_base))

    def test_guarded_solves_name_their_stages(self):
        # A guarded frame's or step's iterations come from several solves; "stage" tells them apart.
        squashed = self.V * np.array([1.0, 0.03, 1.0])  # thinner than the layer: the guard mends it
        deformer = gshell.Deformer(self.shell)
        updates = []
        deformer.solve(squashed, progress=updates.append)
        self.assertEqual(deformer.last["method"], "mended")
        paper = [u for u in updates if u["stage"] == "paper"]
        self.assertEqual(updates[:len(paper)], paper)
        self.assertEqual([u["iteration"] for u in paper], list(range(1, deformer.last["iterations"] + 1)))
        self.assertEqual({u["stage"] for u in updates[len(paper):]}, {"mend"})
        self.assertEqual(len(updates) - len(paper), deformer.last["guarded_iterations"])

        poser = gshell.Poser(self.shell, solver="single")
        updates = []
        poser.solve(HANDLES, steps=1, progress=updates.append)
        self.assertEqual(updates[0]["stage"], "paper")
        for u in updates:
            self.assertEqual(set(u), {"step", "steps", "stage", "iteration", "energy", "seconds"})
            self.assertRegex(u["stage"], r"^(paper|mend|drag( \d+/\d+)?)$")

    def test_bad_progress_raises_value_error(self):
        with self.assertRaises(ValueError):
            gshell.generate(self.V, self.F, thickness=0.05, progress=3)

    def test_a_callback_using_its_own_object_gets_an_error_not_a_deadlock(self):
        # The callback runs inside solve(), which holds the object: reading it from there waited for
        # itself forever, and Ctrl-C could not end the wait.
        d = gshell.Deformer(self.shell)
        p = gshell.Poser(self.shell)
        calls = [(d, lambda cb: d.solve(self.shell.base * 1.5, tolerance=0, progress=cb),
                  [lambda u: d.vertices, lambda u: d.last, lambda u: d.reset()]),
                 (p, lambda cb: p.solve(HANDLES, progress=cb), [lambda u: p.vertices, lambda u: p.last])]
        for obj, solve, callbacks in calls:
            for callback in callbacks:
                with self.subTest(obj=type(obj).__name__), self.assertRaisesRegex(RuntimeError, " is busy: its solve"):
                    solve(callback)
        # Both are usable afterwards.
        self.assertEqual(d.solve(self.shell.base).shape, self.shell.top.shape)
        self.assertEqual(p.solve(HANDLES)[1].shape, self.shell.top.shape)


if __name__ == "__main__":
    unittest.main()
