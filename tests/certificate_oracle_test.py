"""gshell's exact certificate against an independent one (support/exact_certificate.py: Python
integers, other algorithms): the counts in report.json must be the ones the independent check
finds, on valid shells and on shells with inverted tets and every kind of intersection.

Run by ctest as `python3 certificate_oracle_test.py` with GSHELL_CLI naming the CLI.
"""
import json
import os
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), 'support'))
import exact_certificate as oracle  # noqa: E402

GSHELL = os.environ.get('GSHELL_CLI', 'gshell')
COUNTS = ('inverted_tets', 'top_self_intersections', 'top_base_intersections', 'wall_intersections')


def write_obj(path, V, F):
    with open(path, 'w') as f:
        f.writelines('v %r %r %r\n' % tuple(v) for v in V)
        f.writelines('f %d %d %d\n' % tuple(i + 1 for i in t) for t in F)


def run(command):
    # The warnings an invalid shell brings are expected here; they are shown only if the run fails.
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise AssertionError(' '.join(command) + ' failed: ' + done.stderr)


def grid(nx, ny, place):
    """An nx x ny grid of squares cut into triangles, vertex (i, j) at place(i / nx, j / ny)."""
    V = [place(i / nx, j / ny) for j in range(ny + 1) for i in range(nx + 1)]
    F = []
    for j in range(ny):
        for i in range(nx):
            a = j * (nx + 1) + i
            F += [(a, a + 1, a + nx + 2), (a, a + nx + 2, a + nx + 1)]
    return V, F


class CertificateAgreesWithAnIndependentExactCheck(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory(prefix='gshell-oracle-')

    def tearDown(self):
        self.dir.cleanup()

    def path(self, name):
        return os.path.join(self.dir.name, name)

    def generate(self, name, *args):
        out = self.path(name)
        run([GSHELL, 'generate', *args, '-o', out, '--quiet'])
        with open(os.path.join(out, 'report.json')) as f:
            return out, json.load(f)

    def assert_agrees(self, folder, report, base='base.obj', top='top.obj'):
        base_V, F = oracle.read_obj(os.path.join(folder, base))
        top_V, top_F = oracle.read_obj(os.path.join(folder, top))
        self.assertTrue((F == top_F).all())
        mine = oracle.certify(base_V, top_V, F)
        self.assertEqual(mine['undecided'], {})  # no flat triangles sharing an edge in these cases
        for key in COUNTS:
            self.assertEqual(report['certificate'][key], mine[key], key)
        self.assertEqual(report['base_self_intersections'], mine['base_self_intersections'])
        self.assertEqual(report['valid'], all(mine[k] == 0 for k in COUNTS + ('base_self_intersections',)))
        return mine

    def test_oracle_decides_hand_built_pairs(self):
        # The independent check itself, on pairs whose answer is known: touching at a corner,
        # crossing, coplanar overlap, sharing a vertex only, sharing an edge, folded flat on it.
        P = [(0, 0, 0), (4, 0, 0), (0, 4, 0), (1, 1, 0), (1, 1, 4), (1, 1, -4), (4, 4, 0), (2, 0, 0),
             (0, 0, 4), (4, 0, 4), (1, -3, 0), (3, 3, 0)]
        self.assertTrue(oracle.pair_meets(P, (0, 1, 2), (3, 4, 5)))    # a triangle through it
        self.assertTrue(oracle.pair_meets(P, (0, 1, 2), (3, 4, 8)))    # a corner on its face
        self.assertFalse(oracle.pair_meets(P, (0, 1, 2), (6, 9, 4)))   # apart
        self.assertTrue(oracle.pair_meets(P, (0, 1, 2), (3, 6, 7)))    # coplanar overlap
        self.assertFalse(oracle.pair_meets(P, (0, 1, 2), (0, 8, 9)))   # only the shared vertex
        self.assertFalse(oracle.pair_meets(P, (0, 1, 2), (0, 1, 8)))   # only the shared edge
        self.assertFalse(oracle.pair_meets(P, (0, 1, 2), (1, 0, 10)))  # coplanar, across the edge
        self.assertTrue(oracle.pair_meets(P, (0, 1, 2), (0, 1, 11)))   # folded flat onto it
        self.assertTrue(oracle.pair_meets(P, (0, 1, 2), (0, 11, 8)))   # shared vertex, and more
        tets = oracle.prism_tets(oracle.np.array([[0, 1, 2]]), 3)
        top = [(0, 0, 1), (4, 0, 1), (0, 4, 1)]
        self.assertTrue(all(oracle.orient3d(*((P[:3] + top)[i] for i in t)) > 0 for t in tets))

    def fold(self):
        # A strip folded into a V a little narrower than the offset.
        V, F = grid(8, 4, lambda u, v: (0.3 * (u - 0.5), v, 2.0 * abs(u - 0.5)))
        write_obj(self.path('fold.obj'), V, F)
        return self.path('fold.obj')

    def test_valid_guarded_shells(self):
        for name, args in (('sphere', ['builtin:sphere:2', '--thickness-ratio', '0.05']),
                           ('fold', [self.fold(), '--thickness', '0.25']),
                           ('torus', ['builtin:torus:24', '--thickness', '0.6']),
                           ('plane', ['builtin:plane:6', '--thickness-ratio', '0.2', '--method', 'curvature'])):
            with self.subTest(name):
                folder, report = self.generate(name, *args)
                self.assertTrue(report['valid'])
                self.assert_agrees(folder, report)

    def test_a_thick_offset_torus_inverts_tets_and_crosses_its_top(self):
        folder, report = self.generate('torus', 'builtin:torus:24', '--thickness', '0.6', '--method', 'offset')
        mine = self.assert_agrees(folder, report)
        self.assertGreater(mine['inverted_tets'], 0)
        self.assertGreater(mine['top_self_intersections'], 0)

    def test_a_tight_open_fold_inverts_tets_and_crosses_its_walls_and_base(self):
        # Offset along the vertex normals, the arms' tops run into the other arm and the walls.
        folder, report = self.generate('fold', self.fold(), '--thickness', '0.25', '--method', 'offset')
        mine = self.assert_agrees(folder, report)
        self.assertGreater(mine['inverted_tets'], 0)
        self.assertGreater(mine['top_base_intersections'], 0)
        self.assertGreater(mine['wall_intersections'], 0)

    def test_a_base_crossing_itself(self):
        a_V, a_F = grid(4, 4, lambda u, v: (u, v, 0.5))
        b_V, b_F = grid(4, 4, lambda u, v: (u + 0.05, 0.5, v))
        F = a_F + [(i + len(a_V), j + len(a_V), k + len(a_V)) for i, j, k in b_F]
        write_obj(self.path('cross.obj'), a_V + b_V, F)
        folder, report = self.generate('cross', self.path('cross.obj'), '--thickness', '0.05', '--method', 'offset')
        mine = self.assert_agrees(folder, report)
        self.assertGreater(mine['base_self_intersections'], 0)

    def test_metrics_on_tops_that_touch_exactly(self):
        # Two sheets 1 apart, each top lifted by exactly representable amounts: touching the other
        # sheet's top (0.5 + 0.5), then a 2^-40 gap; only the touching one is invalid.
        for lift, touching in ((0.5, True), (0.5 - 2.0 ** -40, False)):
            with self.subTest(lift=lift):
                low_V, F = grid(2, 2, lambda u, v: (u, v, 0.0))
                high_V, _ = grid(2, 2, lambda u, v: (u, v, 1.0))
                n = len(low_V)
                faces = F + [(i + n, k + n, j + n) for i, j, k in F]  # the upper sheet faces down
                top = [(x, y, lift) for x, y, _ in low_V] + [(x, y, 1.0 - lift) for x, y, _ in high_V]
                write_obj(self.path('base.obj'), low_V + high_V, faces)
                write_obj(self.path('top.obj'), top, faces)
                run([GSHELL, 'metrics', self.path('base.obj'), self.path('top.obj'), '--thickness', '0.5',
                     '-o', self.path('m.json'), '--quiet'])
                with open(self.path('m.json')) as f:
                    report = json.load(f)
                mine = self.assert_agrees(self.dir.name, report)
                self.assertEqual(mine['top_self_intersections'] > 0, touching)


if __name__ == '__main__':
    unittest.main(verbosity=2)
