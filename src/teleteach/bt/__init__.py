"""The behaviour tree that the operator edits online: tree from config, ChangeTree semantics, skill library, ROS layer.

Modules: :mod:`~teleteach.bt.behaviours` (PauseCondition, skill leaves, edit-proof composites),
:mod:`~teleteach.bt.tree` (yaml format), :mod:`~teleteach.bt.library` (skills), :mod:`~teleteach.bt.editor`
(/change_tree without ROS), :mod:`~teleteach.bt.teaching` (ticks, pause, help requests, persistence) and
:mod:`~teleteach.bt.ros` (topics, services and action-client leaves).
"""
