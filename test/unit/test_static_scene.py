"""static_scene's belief (teleteach.perception.static): the scene file's objects, the grasped product following the
hand until the fingers open, nothing attached without a product at the TCP."""

import dataclasses

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from teleteach.core.paths import config_file
from teleteach.core.scene import load_objects
from teleteach.perception.static import StaticScene, StaticSceneConfig

DOWN = Rotation.from_euler("x", np.pi)  # TCP z pointing down
HOLD = np.array([0.0, 0.0, 0.035])  # [m] the TCP above a held product's centre
LIFT = np.array([0.0, 0.0, 0.2])


@pytest.fixture
def scene():
    return StaticScene(load_objects(), attach_distance=0.06, release_margin=0.005)


def test_the_file_is_the_scene_until_something_is_grasped(scene):
    observed = scene.observed(3.0)
    objects = load_objects()
    assert observed.stamp == 3.0
    assert sorted(observed.products) == sorted(product.name for product in objects.products)
    np.testing.assert_allclose(observed.product("product_pick_1").position, objects.products[0].position)
    assert observed.gaps == objects.gaps and list(observed.tables) == ["pick_table"]


def test_the_grasped_product_follows_the_hand_and_stays_where_it_is_released(scene):
    centre = np.array(load_objects().products[0].position)  # product_pick_1
    tcp = centre + HOLD
    assert scene.grasped(tcp, DOWN.as_quat(), 0.05) == "product_pick_1"
    # the hand lifts, turns 90 degrees about the vertical and moves to the shelf: the product keeps its place in it
    turn = Rotation.from_euler("z", np.pi / 2)
    moved_tcp = np.array([2.06, 0.0, 0.755])
    assert scene.follow(moved_tcp, (turn * DOWN).as_quat(), 0.05) is None
    carried = scene.observed(4.0).product("product_pick_1")
    np.testing.assert_allclose(carried.position, moved_tcp - HOLD, atol=1e-9)
    assert carried.yaw == pytest.approx(np.pi / 2)
    # squeezing a little tighter or looser within the margin keeps it; opening beyond releases it where it is
    assert scene.follow(moved_tcp, (turn * DOWN).as_quat(), 0.054) is None
    assert scene.follow(moved_tcp, (turn * DOWN).as_quat(), 0.056) == "product_pick_1"
    assert scene.follow(moved_tcp + LIFT, DOWN.as_quat(), 0.08) is None
    np.testing.assert_allclose(scene.observed(5.0).product("product_pick_1").position, carried.position)


def test_nothing_is_attached_without_a_product_at_the_tcp_or_while_one_is_held(scene):
    assert scene.grasped([1.0, 1.0, 1.0], DOWN.as_quat(), 0.0) is None
    centre = np.array(load_objects().products[1].position)  # product_pick_2
    assert scene.grasped(centre + HOLD, DOWN.as_quat(), 0.05) == "product_pick_2"
    other = np.array(load_objects().products[0].position)
    assert scene.grasped(other + HOLD, DOWN.as_quat(), 0.05) is None
    assert scene.held.name == "product_pick_2"


def test_the_node_s_parameters_are_its_yaml_and_a_bad_one_is_named():
    values = yaml.safe_load(config_file("static_scene.yaml").read_text())
    config = StaticSceneConfig.from_mapping(values)
    assert dataclasses.asdict(config) == dict(values, finger_joints=tuple(values["finger_joints"]))
    with pytest.raises(ValueError, match=r"^~rate must be a positive number of Hz, got 0.0$"):
        StaticSceneConfig.from_mapping(dict(values, rate=0.0))
    del values["release_margin"]
    with pytest.raises(ValueError, match=r"\(config/static_scene.yaml\): missing release_margin; unknown x$"):
        StaticSceneConfig.from_mapping(dict(values, x=1))
