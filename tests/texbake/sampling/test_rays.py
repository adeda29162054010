"""texbake.sampling.rays: first hits and distances in the caller's units, and casts that run beside other threads."""

import threading
import time

import numpy as np
import trimesh

from texbake.sampling.rays import Scene

DOWN = np.array([0.0, 0.0, -1.0])


def far_sphere(subdivisions=3):
    """A unit icosphere centred far from the origin (the float32 map must re-centre it)."""
    sphere = trimesh.creation.icosphere(subdivisions=subdivisions)
    return sphere.vertices + [1e5, -2e5, 3e5], sphere.faces


def test_first_hit_distances_in_the_callers_units():
    vertices, faces = far_sphere()
    scene = Scene(vertices, faces)
    centre = np.array([1e5, -2e5, 3e5])
    origins = centre + [[0.0, 0.0, 5.0], [3.0, 0.0, 5.0], [0.0, 0.0, 0.0]]
    face, distance = scene.first_hit(origins, DOWN)
    assert face[0] >= 0 and face[1] == -1 and face[2] >= 0
    assert abs(distance[0] - 4.0) < 2e-2 and np.isinf(distance[1])  # the icosphere's faces lie within 1.3% of the unit sphere
    assert 0.98 < distance[2] < 1.001  # from inside, the far side
    assert scene.first_hit(origins[:1], DOWN, max_distance=3.0)[0][0] == -1
    np.testing.assert_array_equal(scene.first_face(origins, DOWN), face)
    assert scene.first_face(np.zeros((0, 3)), DOWN).shape == (0,)


def test_two_threads_casting_at_once_answer_as_one():
    rng = np.random.default_rng(6)
    vertices, faces = far_sphere(5)
    scene = Scene(vertices, faces)
    n = 200_000
    origins = vertices.mean(axis=0) + (rng.random((2, n, 3)) - 0.5) * 4
    directions = rng.normal(size=(2, n, 3))
    alone = [scene.first_hit(origins[k], directions[k]) for k in range(2)]
    out: list = [None, None]
    start = threading.Barrier(2)

    def cast(k):
        start.wait()
        out[k] = [scene.first_hit(origins[k], directions[k]) for _ in range(3)]

    threads = [threading.Thread(target=cast, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for k in range(2):
        for face, distance in out[k]:
            np.testing.assert_array_equal(face, alone[k][0])
            np.testing.assert_array_equal(distance, alone[k][1])


def spin_rate(target) -> float:
    """Loops of this thread's Python a second while ``target`` runs in another thread
    (timed from before its start: a thread that holds the GIL may take it at once)."""
    worker = threading.Thread(target=target)
    count, start = 0, time.perf_counter()
    worker.start()
    while worker.is_alive():
        count += 1
    return count / (time.perf_counter() - start)


def test_casts_release_the_gil():
    """Python runs in another thread while a cast is under way (embreex >= 4.4). A call
    that holds the GIL leaves the other thread a few percent of its speed beside a
    sleeping thread; a cast without it leaves a good part even on a loaded machine."""
    rng = np.random.default_rng(7)
    tri = rng.random((3000, 3, 3)) * 10  # large overlapping triangles: slow rays
    scene = Scene(tri.reshape(-1, 3), np.arange(9000).reshape(-1, 3))
    origins = (rng.random((60_000, 3)) - 0.5) * 10 + 5
    took = []

    def cast():
        t = time.perf_counter()
        scene.first_face(origins, DOWN)
        took.append(time.perf_counter() - t)

    share = spin_rate(cast) / spin_rate(lambda: time.sleep(0.2))
    assert took[0] > 0.05 and share > 0.15, (took, share)


def test_the_compiled_scene_finds_what_embreexs_own_binding_finds():
    # the same Embree library either way; rays along grid lines, through vertices and
    # diagonals (ties between faces, where the traversal order picks one) and at random
    from embreex import mesh_construction, rtcore_scene

    from texbake.sampling import rays

    assert rays.compiled()  # embreex's wheel ships the library beside it
    side = 32
    t = np.linspace(0.0, 1.0, side + 1)
    x, y = np.meshgrid(t, t)
    vertices = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1).astype(np.float32)
    corner = (np.arange(side)[:, None] * (side + 1) + np.arange(side)).ravel()
    quads = np.stack([corner, corner + 1, corner + side + 2, corner + side + 1], axis=1)
    faces = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    g = np.linspace(0.0, 1.0, 4 * side + 1)
    gx, gy = np.meshgrid(g, g)
    rng = np.random.default_rng(3)
    origins = np.concatenate([np.stack([gx.ravel(), gy.ravel(), np.ones(gx.size)], axis=1),
                              np.c_[rng.random((20000, 2)) * 1.2 - 0.1, np.ones(20000)]]).astype(np.float32)
    theirs = rtcore_scene.EmbreeScene()
    mesh_construction.TriangleMesh(theirs, vertices, faces.astype(np.int32))
    down = DOWN.astype(np.float32)[None]
    ours = Scene(vertices, faces, recentre=False)
    assert np.array_equal(ours.first_face(origins, DOWN), theirs.run(origins, down))
    sphere_vertices, sphere_faces = far_sphere(3)
    ours = Scene(sphere_vertices, sphere_faces)
    theirs = rtcore_scene.EmbreeScene()
    mapped = ((sphere_vertices - ours._centre) / ours._scale).astype(np.float32)
    mesh_construction.TriangleMesh(theirs, mapped, sphere_faces.astype(np.int32))
    origins = sphere_vertices.mean(axis=0) + (rng.random((20000, 3)) - 0.5) * 4
    directions = rng.normal(size=(20000, 3))
    face, distance = ours.first_hit(origins, directions)
    res = theirs.run(ours._origins(origins), directions.astype(np.float32), output=1)
    assert (face >= 0).sum() > 2000 and np.array_equal(face, res["primID"])  # measured 2912 hits
    assert np.array_equal(distance[face >= 0], res["tfar"][face >= 0].astype(np.float64) * ours._scale)
