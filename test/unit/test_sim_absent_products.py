"""A product left out of the scene (robot_sim's ~absent_products): the simulation starts without it, so a pick fails."""

import pytest

from teleteach.core.scene import SceneError, load_scene
from teleteach.run.sim_robot import SimRobot
from teleteach.sim.robot_sim import RobotSim


def test_left_out_products_are_not_in_the_scene_nor_in_the_simulation():
    full = load_scene()
    scene = full.without_products(["product_pick_1"])
    assert [product.name for product in scene.products] == [p.name for p in full.products if p.name != "product_pick_1"]
    assert scene.gaps == full.gaps and scene.shelf == full.shelf
    sim = RobotSim(scene)
    try:
        positions = SimRobot(sim).product_positions()
        assert "product_pick_1" not in positions and "product_pick_2" in positions
        assert set(positions) == {product.name for product in scene.products}
    finally:
        sim.close()


def test_a_single_name_and_an_empty_list_are_accepted():
    full = load_scene()
    assert full.without_products("product_pick_2").products == full.without_products(["product_pick_2"]).products
    assert full.without_products([]) == full


def test_an_unknown_product_is_refused_and_nothing_is_left_out():
    full = load_scene()
    count = len(full.products)
    with pytest.raises(SceneError, match="cannot leave out product_pick_9: no such product in the scene"):
        full.without_products(["product_pick_1", "product_pick_9"])
    assert len(full.products) == count
