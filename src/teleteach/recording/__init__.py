"""Recording of teaching sessions: rosbag record/replay commands, offline reading with rosbags, report plots."""
