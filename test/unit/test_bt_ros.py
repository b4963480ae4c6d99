"""The ROS messages of the tree, built without a master: log/tree records, and the pre-serialised BehaviourTree."""

import io

import rospy
from bt_support import SkillWorld, thesis_tree

from teleteach.bt.ros import PreserializedTree, _behaviour
from teleteach.msg import Behaviour, BehaviourTree


def serialized(message):
    buffer = io.BytesIO()
    message.serialize(buffer)
    return buffer.getvalue()


def test_preserialized_tree_is_byte_identical_to_genpy():
    tree = thesis_tree(SkillWorld(ticks=3))
    tree.tick()
    records, _ = tree.records()
    behaviours = [_behaviour(record) for record in records]
    plain = BehaviourTree(behaviours=behaviours)
    plain.header.stamp = rospy.Time(12, 345)
    plain.header.frame_id = "tree"
    fast = PreserializedTree([serialized(behaviour) for behaviour in behaviours])
    fast.header.stamp = rospy.Time(12, 345)
    fast.header.frame_id = "tree"
    # Expect the same bytes on the wire, and a subscriber to read every node back
    assert serialized(fast) == serialized(plain)
    decoded = BehaviourTree().deserialize(serialized(fast))
    assert [b.name for b in decoded.behaviours] == [r.name for r in records]


def test_log_tree_records_mirror_py_trees_msgs():
    tree = thesis_tree(SkillWorld(ticks=3, failures={"LookToShelf": ["camera blocked"]}))
    tree.tick()
    records, tip = tree.records()
    messages = {record.name: _behaviour(record) for record in records}
    # Expect ids linking parents and children, types, statuses, messages and activity as py_trees_msgs has them
    root, pause, execution = messages["Root"], messages["PauseCondition"], messages["BehaviorExecution"]
    assert root.parent_id == "" and root.child_ids == [pause.own_id, execution.own_id]
    assert execution.parent_id == root.own_id and len(execution.child_ids) == 10
    assert (root.type, execution.type, pause.type) == (Behaviour.SELECTOR, Behaviour.SEQUENCE, Behaviour.BEHAVIOUR)
    assert messages["LookToShelf"].status == Behaviour.RUNNING and messages["LookToShelf"].is_active
    assert messages["PickItem"].status == Behaviour.INVALID and not messages["PickItem"].is_active
    assert execution.tip_id == messages["LookToShelf"].own_id and tip.name == "LookToShelf"
    assert messages["LookToShelf"].class_name == "LookToShelf" and execution.class_name == "EditableSequence"
    for _ in range(3):
        tree.tick()
    records, _ = tree.records()
    failed = next(record for record in records if record.name == "LookToShelf")
    # Expect a leaf waiting for the operator to be shown as the failed skill it is, with the reason
    assert _behaviour(failed).status == Behaviour.FAILURE
    assert failed.message == "failed: camera blocked (waiting for the operator)"


def test_unchanged_nodes_reuse_their_records():
    tree = thesis_tree(SkillWorld(ticks=5))
    tree.tick()
    first, _ = tree.records()
    tree.tick()
    second, _ = tree.records()
    # Expect only the running leaf (its message counts down) and nothing else to be rebuilt
    rebuilt = [b.name for a, b in zip(first, second) if a is not b]
    assert rebuilt == ["LookToShelf"]
