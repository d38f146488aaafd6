"""create_rays_pinhole in Open3D's two forms: Open3D's formula on a small camera, the look-at
form equal to its matrices, and bad cameras refused."""

import numpy as np
import pytest

import raybatch

make = raybatch.RaycastingScene.create_rays_pinhole


def test_matrix_form_follows_open3d():
    # Open3D: origin -R^T t, direction R^T K^-1 (x + 0.5, y + 0.5, 1).
    k = np.array([[2.0, 0, 1.5], [0, 4.0, 1.0], [0, 0, 1]])
    e = np.eye(4)
    e[:3, 3] = [1, 2, 3]
    rays = make(k, e, 3, 2)
    assert rays.shape == (2, 3, 6) and rays.dtype == np.float32
    assert np.all(rays[..., :3] == np.float32([-1, -2, -3]))
    x, y = np.meshgrid(np.arange(3) + 0.5, np.arange(2) + 0.5)
    expected = np.stack([(x - 1.5) / 2, (y - 1.0) / 4, np.ones_like(x)], -1)
    assert np.allclose(rays[..., 3:], expected, atol=1e-7)


def test_look_at_form_equals_its_matrices():
    centre, eye, up = np.array([0.1, 0.2, 0.0]), np.array([1.0, 2.0, 3.0]), np.array([0.0, 1.0, 0.0])
    rays = make(60.0, centre, eye, up, 40, 30)
    assert rays.shape == (30, 40, 6)
    assert np.allclose(rays[..., :3], eye, atol=1e-6)
    # The middle ray looks at the centre; up is up in the picture.
    middle = rays[14:16, 19:21, 3:].reshape(-1, 3).mean(0)
    view = (centre - eye) / np.linalg.norm(centre - eye)
    assert np.allclose(middle / np.linalg.norm(middle), view, atol=1e-3)
    assert np.dot(rays[0, 20, 3:] - rays[-1, 20, 3:], up) > 0
    # The same camera as matrices (Open3D builds these from the look-at form).
    f = 0.5 * 40 / np.tan(np.radians(30))
    k = np.array([[f, 0, 20], [0, f, 15], [0, 0, 1]])
    w = (eye - centre) / np.linalg.norm(eye - centre)
    u = np.cross(up, w)
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    r = np.stack([u, -v, -w])
    e = np.eye(4)
    e[:3, :3], e[:3, 3] = r, -r @ eye
    assert np.allclose(make(k, e, 40, 30), rays, atol=1e-6)
    keywords = make(fov_deg=60.0, center=centre, eye=eye, up=up, width_px=40, height_px=30)
    assert np.array_equal(keywords, rays)


def test_rays_hit_what_the_camera_sees():
    scene = raybatch.RaycastingScene()
    scene.add_triangles(np.float32([[-1, -1, 0], [1, -1, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    rays = make(40.0, [0, 0, 0], [0, 0, 5], [0, 1, 0], 9, 9)
    assert scene.test_occlusions(rays)[4, 4] and not scene.test_occlusions(rays)[0, 0]


@pytest.mark.parametrize(
    "args, message",
    [
        ((np.eye(3), np.eye(4), 0, 2), "width_px"),
        ((np.eye(3), np.eye(4), 2, True), "height_px"),
        ((np.zeros((3, 3)), np.eye(4), 2, 2), "singular"),
        ((np.eye(2), np.eye(4), 2, 2), "intrinsic_matrix must be 9 numbers"),
        (("wide", np.eye(4), 2, 2), "intrinsic_matrix must be 9 numbers"),
        ((60.0, [0, 0, 0], [0, 0, 0], [0, 1, 0], 4, 4), "eye must differ"),
        ((60.0, [0, 0, 0], [0, 1, 0], [0, 1, 0], 4, 4), "up must not be along"),
        ((200.0, [0, 0, 0], [0, 0, 1], [0, 1, 0], 4, 4), "fov_deg"),
        ((60.0, [0, 0], [0, 0, 1], [0, 1, 0], 4, 4), "center must be 3 numbers"),
        ((60.0, [0, 0, np.nan], [0, 0, 1], [0, 1, 0], 4, 4), "finite"),
        ((1, 2, 3), "takes"),
    ],
)
def test_bad_cameras_are_value_errors(args, message):
    with pytest.raises(ValueError, match=message):
        make(*args)
