"""An exact validity certificate of a shell, written apart from gshell's C++ one (no shared code,
other algorithms) so that each can be checked against the other.

Every decision is exact: a double is a dyadic rational, so all coordinates are scaled to Python
integers over one common power-of-two denominator and every orientation is an integer determinant.
numpy serves only the bounding-box broad phase. Meant for small shells (a few thousand triangles).

The definitions are docs/validity.md's: tets cut from each prism by the vertex-id rule must be
positive; boundary triangles (base reversed, top, two walls per boundary edge of an open base) may
meet only at the vertices and edges they share.
"""
import itertools

import numpy as np


def read_obj(path):
    """Positions and triangles of an OBJ (polygons fanned), as gshell writes them."""
    V, F = [], []
    with open(path) as f:
        for line in f:
            if line.startswith('v '):
                V.append([float(t) for t in line.split()[1:4]])
            elif line.startswith('f '):
                ids = [int(t.split('/')[0]) - 1 for t in line.split()[1:]]
                F += [(ids[0], ids[k], ids[k + 1]) for k in range(1, len(ids) - 1)]
    return np.array(V, dtype=np.float64).reshape(-1, 3), np.array(F, dtype=np.int64).reshape(-1, 3)


def exact_points(P):
    """The points as integer triples, all scaled by the same power of two (exact)."""
    ratios = [float(x).as_integer_ratio() for x in P.ravel().tolist()]
    denominator = max(d for _, d in ratios)
    ints = [n * (denominator // d) for n, d in ratios]
    return [tuple(ints[3 * i:3 * i + 3]) for i in range(len(P))]


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(u, v):
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


def orient3d(a, b, c, d):
    """det[b - a, c - a, d - a]: positive when d lies on the side abc's normal points to."""
    u, v, w = sub(b, a), sub(c, a), sub(d, a)
    n = cross(v, w)
    return u[0] * n[0] + u[1] * n[1] + u[2] * n[2]


def sign(x):
    return (x > 0) - (x < 0)


def normal(a, b, c):
    return cross(sub(b, a), sub(c, a))


def flat(a, b, c):
    return normal(a, b, c) == (0, 0, 0)


def drop_axis(n):
    """The two axes kept when projecting a plane of normal n (the largest component dropped)."""
    k = max(range(3), key=lambda i: abs(n[i]))
    return [i for i in range(3) if i != k]


def project(points, axes):
    return [(p[axes[0]], p[axes[1]]) for p in points]


def orient2d(a, b, c):
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def within(p, q, r):
    """r, collinear with p and q, lies on the closed segment pq."""
    return all(min(p[k], q[k]) <= r[k] <= max(p[k], q[k]) for k in range(len(r)))


def segments_meet_2d(p, q, r, s):
    d1, d2 = sign(orient2d(p, q, r)), sign(orient2d(p, q, s))
    d3, d4 = sign(orient2d(r, s, p)), sign(orient2d(r, s, q))
    if d1 * d2 < 0 and d3 * d4 < 0:
        return True
    return ((d1 == 0 and within(p, q, r)) or (d2 == 0 and within(p, q, s)) or
            (d3 == 0 and within(r, s, p)) or (d4 == 0 and within(r, s, q)))


def in_triangle_2d(p, a, b, c):
    s = (sign(orient2d(a, b, p)), sign(orient2d(b, c, p)), sign(orient2d(c, a, p)))
    return min(s) >= 0 or max(s) <= 0


def triangles_meet_2d(A, B):
    if any(in_triangle_2d(p, *B) for p in A) or any(in_triangle_2d(p, *A) for p in B):
        return True
    return any(segments_meet_2d(A[i], A[(i + 1) % 3], B[j], B[(j + 1) % 3]) for i in range(3) for j in range(3))


def segment_meets_triangle(p, q, a, b, c):
    """The closed segment pq and the closed triangle abc (not flat) have a point in common."""
    sp, sq = sign(orient3d(a, b, c, p)), sign(orient3d(a, b, c, q))
    if sp * sq > 0:
        return False
    if sp == 0 and sq == 0:
        axes = drop_axis(normal(a, b, c))
        pp, qq, aa, bb, cc = project([p, q, a, b, c], axes)
        return (in_triangle_2d(pp, aa, bb, cc) or in_triangle_2d(qq, aa, bb, cc) or
                any(segments_meet_2d(pp, qq, x, y) for x, y in ((aa, bb), (bb, cc), (cc, aa))))
    s = (sign(orient3d(p, q, a, b)), sign(orient3d(p, q, b, c)), sign(orient3d(p, q, c, a)))
    return min(s) >= 0 or max(s) <= 0


def triangles_meet(A, B):
    """The closed triangles A and B (neither flat) have a point in common."""
    sides_b = [sign(orient3d(*A, b)) for b in B]
    if sides_b == [0, 0, 0]:
        axes = drop_axis(normal(*A))
        return triangles_meet_2d(project(A, axes), project(B, axes))
    if min(sides_b) > 0 or max(sides_b) < 0:
        return False
    sides_a = [sign(orient3d(*B, a)) for a in A]
    if min(sides_a) > 0 or max(sides_a) < 0:
        return False
    return any(segment_meets_triangle(A[i], A[(i + 1) % 3], *B) or segment_meets_triangle(B[i], B[(i + 1) % 3], *A)
               for i in range(3))


def origin_in_hull(S):
    """The origin lies in the convex hull of the integer points S (Caratheodory: some subset of at
    most four points holds it)."""
    O = (0, 0, 0)
    S = list(set(S))
    if O in S:
        return True
    for a, b in itertools.combinations(S, 2):
        if cross(a, b) == O and all(min(a[k], b[k]) <= 0 <= max(a[k], b[k]) for k in range(3)):
            return True
    for a, b, c in itertools.combinations(S, 3):
        n = normal(a, b, c)
        if n != O and orient3d(a, b, c, O) == 0 and in_triangle_2d((0, 0), *project([a, b, c], drop_axis(n))):
            return True
    for a, b, c, d in itertools.combinations(S, 4):
        s = sign(orient3d(a, b, c, d))
        if s and all(sign(x) * s >= 0 for x in (orient3d(O, b, c, d), orient3d(a, O, c, d),
                                                 orient3d(a, b, O, d), orient3d(a, b, c, O))):
            return True
    return False


def pointed_pieces(U):
    """The generators of a cone at a vertex, split where a flat triangle runs through the vertex."""
    if not U or not origin_in_hull(U):
        return [U] if U else []
    d = U[0]  # U lies on a line through the vertex, in both directions
    dot = [sum(u[k] * d[k] for k in range(3)) for u in U]
    return [x for x in ([u for u, t in zip(U, dot) if t > 0], [u for u, t in zip(U, dot) if t < 0]) if x]


def flat_pair_meets(A, B, shared_at):
    """As pair_meets, where A or B is flat. shared_at: None (nothing shared) or the positions of the
    one shared vertex in A and B. A flat pair sharing an edge is not decided (None)."""
    if shared_at is None:
        return origin_in_hull([sub(a, b) for a in A for b in B])
    p = A[shared_at[0]]
    U = [u for u in (sub(a, p) for a in A) if u != (0, 0, 0)]
    W = [w for w in (sub(b, p) for b in B) if w != (0, 0, 0)]
    # They meet beyond p when their cones at p share a direction.
    return any(origin_in_hull(u + [(-w[0], -w[1], -w[2]) for w in v]) for u in pointed_pieces(U) for v in pointed_pieces(W))


def pair_meets(P, ta, tb):
    """Triangles ta, tb (vertex-id triples) have a point in common beyond the vertices and edges
    they share: True, False, or None (flat triangles sharing an edge, not decided here)."""
    shared = set(ta) & set(tb)
    A, B = [P[i] for i in ta], [P[i] for i in tb]
    if len(shared) == 3:
        return True
    if flat(*A) or flat(*B):
        if len(shared) == 2:
            return None
        at = None if not shared else (list(ta).index(next(iter(shared))), list(tb).index(next(iter(shared))))
        return flat_pair_meets(A, B, at)
    if not shared:
        return triangles_meet(A, B)
    if len(shared) == 2:
        p, q = sorted(shared)
        a, b = [i for i in ta if i not in shared][0], [i for i in tb if i not in shared][0]
        if orient3d(P[p], P[q], P[a], P[b]) != 0:
            return False
        pp, qq, aa, bb = project([P[p], P[q], P[a], P[b]], drop_axis(normal(*A)))
        return sign(orient2d(pp, qq, aa)) * sign(orient2d(pp, qq, bb)) > 0  # folded onto each other
    p = next(iter(shared))
    a1, a2 = [P[i] for i in ta if i != p]
    b1, b2 = [P[i] for i in tb if i != p]
    return segment_meets_triangle(a1, a2, *B) or segment_meets_triangle(b1, b2, *A)


def prism_tets(F, n):
    """Three tets per face, the prism cut by the vertex-id rule: each side quad's diagonal runs
    from its smallest base id up to the other edge end's top vertex (so neighbours agree)."""
    tets = []
    for ids in F.tolist():
        a, b, c = sorted(range(3), key=lambda i: ids[i])
        local = [[a, b, c, c + 3], [a, b, c + 3, b + 3], [a, a + 3, b + 3, c + 3]]
        if b != (a + 1) % 3:  # the sorted order runs against the face's: keep the tets positive
            for t in local:
                t[2], t[3] = t[3], t[2]
        tets += [[ids[x] if x < 3 else n + ids[x - 3] for x in t] for t in local]
    return tets


def boundary_triangles(F, n):
    """(triangle, part) with part 'B' (base, reversed), 'T' (top) or 'W' (wall)."""
    rows = [((f[0], f[2], f[1]), 'B') for f in F.tolist()] + [((f[0] + n, f[1] + n, f[2] + n), 'T') for f in F.tolist()]
    uses = {}
    for f in F.tolist():
        for k in range(3):
            e = tuple(sorted((f[k], f[(k + 1) % 3])))
            uses[e] = uses.get(e, 0) + 1
    for f in F.tolist():
        for k in range(3):
            i, j = f[k], f[(k + 1) % 3]
            if uses[tuple(sorted((i, j)))] == 1:
                quad = [(i, j, n + j), (i, n + j, n + i)] if i < j else [(i, j, n + i), (j, n + j, n + i)]
                rows += [(t, 'W') for t in quad]
    return rows


def box_overlaps(lo, hi):
    """Index pairs (i < j) of closed boxes that overlap."""
    pairs = []
    for i in range(len(lo) - 1):
        j = np.arange(i + 1, len(lo))
        hit = np.all((lo[i] <= hi[j]) & (lo[j] <= hi[i]), axis=1)
        pairs += [(i, int(k)) for k in j[hit]]
    return pairs


def certify(base_V, top_V, F):
    """The certificate's counts for a shell: inverted_tets, top_self_intersections,
    top_base_intersections, wall_intersections, base_self_intersections, and undecided (flat
    triangles sharing an edge, by kind)."""
    n = len(base_V)
    P_float = np.vstack([base_V, top_V])
    P = exact_points(P_float)
    counts = {'inverted_tets': sum(orient3d(*(P[i] for i in t)) <= 0 for t in prism_tets(F, n))}
    rows = boundary_triangles(F, n)
    tri = np.array([t for t, _ in rows])
    corners = P_float[tri]
    kinds = {}
    undecided = {}
    for i, j in box_overlaps(corners.min(axis=1), corners.max(axis=1)):
        parts = rows[i][1] + rows[j][1]
        kind = 'W' if 'W' in parts else ''.join(sorted(parts))
        meets = pair_meets(P, rows[i][0], rows[j][0])
        if meets is None:
            undecided[kind] = undecided.get(kind, 0) + 1
        elif meets:
            kinds[kind] = kinds.get(kind, 0) + 1
    counts.update(top_self_intersections=kinds.get('TT', 0), top_base_intersections=kinds.get('BT', 0),
                  wall_intersections=kinds.get('W', 0), base_self_intersections=kinds.get('BB', 0),
                  undecided=undecided)
    return counts
