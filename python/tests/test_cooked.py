"""Cooked scenes: saved and loaded (files and bytes) they answer bit for bit as the scene that
was saved, the command line answers a file cooked here, and damaged files are refused."""

import struct
import zlib

import numpy as np
import pytest

import raybatch
from conftest import BUNNY, cli_query

QUERIES = ["cast_rays", "test_occlusions", "count_intersections", "list_intersections"]


def assert_same(a, b, rays):
    for query in QUERIES:
        x, y = getattr(a, query)(rays), getattr(b, query)(rays)
        if isinstance(x, dict):
            assert x.keys() == y.keys()
            for key in x:
                assert np.array_equal(x[key], y[key]), (query, key)
        else:
            assert np.array_equal(x, y), query


@pytest.mark.parametrize("kind", raybatch.COOKED_KINDS)
def test_every_cooked_kind_round_trips(bunny, rays, tmp_path, kind):
    scene = raybatch.RaycastingScene(kind=kind)
    scene.add_triangles(*bunny)
    path = tmp_path / "bunny.rbt"
    scene.save(path)
    assert path.read_bytes() == scene.to_bytes()
    for loaded in (raybatch.RaycastingScene.load(path), raybatch.RaycastingScene.from_bytes(scene.to_bytes())):
        assert loaded.kinds() == [kind]
        assert_same(scene, loaded, rays)


def test_three_geometries_round_trip_and_grow(bunny, rays, tmp_path):
    vertices, triangles = bunny
    scene = raybatch.RaycastingScene()
    for shift in (0.0, 0.03, -0.04):
        scene.add_triangles(vertices + np.float32(shift), triangles)
    loaded = raybatch.RaycastingScene.from_bytes(scene.to_bytes())
    assert loaded.geometry_count() == 3 and loaded.triangle_count() == scene.triangle_count()
    assert_same(scene, loaded, rays)
    # Geometries added to a loaded scene take the next ids.
    assert loaded.add_triangles(vertices + np.float32(0.5), triangles) == 3
    assert scene.add_triangles(vertices + np.float32(0.5), triangles) == 3
    assert_same(scene, loaded, rays)


def test_an_empty_scene_round_trips(rays):
    loaded = raybatch.RaycastingScene.from_bytes(raybatch.RaycastingScene().to_bytes())
    assert loaded.geometry_count() == 0 and not loaded.test_occlusions(rays).any()


def test_the_command_line_answers_a_file_cooked_here(cli, bunny_scene, rays, tmp_path):
    path = tmp_path / "bunny.rbt"
    bunny_scene.save(path)
    expected = cli_query(cli, path, rays, "closest", tmp_path)
    got = bunny_scene.cast_rays(rays)
    assert np.array_equal(got["t_hit"].view(np.uint32), expected["t"].view(np.uint32))
    assert np.array_equal(got["primitive_ids"], expected["id"])


def patched(data, offset, value):
    """`data` with the payload's bytes at `offset` replaced and the CRC-32 made right again."""
    payload = bytearray(data[32:])
    payload[offset : offset + len(value)] = value
    header = bytearray(data[:32])
    header[24:28] = struct.pack("<I", zlib.crc32(payload))
    return bytes(header + payload)


def test_damaged_files_are_value_errors(bunny_scene, tmp_path):
    data = bunny_scene.to_bytes()
    load = raybatch.RaycastingScene.from_bytes
    with pytest.raises(ValueError, match="damaged"):
        load(data[:100] + bytes([data[100] ^ 1]) + data[101:])
    with pytest.raises(ValueError, match="truncated"):
        load(data[: len(data) // 2])
    with pytest.raises(ValueError, match="not a cooked raybatch file"):
        load(b"v 0 0 0\n" * 10)
    with pytest.raises(ValueError, match="not a cooked raybatch file"):
        load(b"")
    newer = data[:8] + struct.pack("<I", raybatch.FORMAT_VERSION + 1) + data[12:]
    with pytest.raises(ValueError, match="this library reads up to format"):
        load(newer)
    # A vertex index past the vertices, checksum made right: the library's mesh check.
    with pytest.raises(ValueError, match="cooked file"):
        load(patched(data, 8, b"\xff" * 64))
    bad = tmp_path / "bad.rbt"
    bad.write_bytes(data[:64])
    with pytest.raises(ValueError, match="truncated"):
        raybatch.RaycastingScene.load(bad)
    with pytest.raises(OSError, match="cannot read"):
        raybatch.RaycastingScene.load(tmp_path / "missing.rbt")


@pytest.mark.parametrize("kind", sorted(set(raybatch.KINDS) - set(raybatch.COOKED_KINDS)))
def test_kinds_that_do_not_cook_say_so(kind):
    scene = raybatch.RaycastingScene(kind=kind)
    scene.add_triangles(np.eye(3, dtype=np.float32), np.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match="cannot be cooked"):
        scene.to_bytes()
