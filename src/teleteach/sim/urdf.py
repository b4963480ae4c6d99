"""The URDF on /robot_description: the mobile base (base_link) with pybullet_data's Panda on it.

Its meshes are the copies this package ships in meshes/panda (pybullet_data's, from franka_ros: Apache-2.0, see
NOTICE), named ``package://teleteach/meshes/panda/...``: RViz on any machine of the ROS network that has teleteach
installed (devel or install space) finds them through its ROS_PACKAGE_PATH.
"""

import xml.etree.ElementTree as ElementTree

from teleteach.control import panda
from teleteach.core.scene import load_site

MESH_PREFIX = "package://meshes/"  # how pybullet_data's panda.urdf names its meshes (relative to itself)
PACKAGE_MESHES = "package://teleteach/meshes/panda/"  # the same files, shipped in this package


def robot_description(mount_height=None, base_size=None):
    """The URDF text of base_link + Panda (panda_link0 mount_height [m] above base_link, a base box base_size [m])."""
    robot_setup = load_site().robot
    mount_height = robot_setup.mount_height if mount_height is None else mount_height
    base_size = robot_setup.base_size if base_size is None else base_size
    robot = ElementTree.fromstring(panda.PANDA_URDF.read_text())
    robot.set("name", "teleteach_panda")
    for mesh in robot.iter("mesh"):
        mesh.set("filename", mesh.get("filename").replace(MESH_PREFIX, PACKAGE_MESHES))
    for element in robot.iter():
        # pybullet's xacro output puts colour-less materials into <collision>: not URDF, drop them
        if element.tag == "collision":
            for material in element.findall("material"):
                element.remove(material)
    header = f"""<robot>
  <material name="panda_white"><color rgba="0.95 0.95 0.95 1.0"/></material>
  <material name="base_grey"><color rgba="0.25 0.25 0.3 1.0"/></material>
  <link name="base_link">
    <visual>
      <origin xyz="0 0 {base_size[2] / 2.0}" rpy="0 0 0"/>
      <geometry><box size="{base_size[0]} {base_size[1]} {base_size[2]}"/></geometry>
      <material name="base_grey"/>
    </visual>
  </link>
  <joint name="base_link_to_panda_link0" type="fixed">
    <parent link="base_link"/>
    <child link="panda_link0"/>
    <origin xyz="0 0 {mount_height}" rpy="0 0 0"/>
  </joint>
</robot>"""
    for index, element in enumerate(ElementTree.fromstring(header)):
        robot.insert(index, element)
    return '<?xml version="1.0"?>\n' + ElementTree.tostring(robot, encoding="unicode")
