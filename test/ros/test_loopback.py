"""Loopback by default: with the environment of build/env.sh (ROS_IP=127.0.0.1 unless the user set ROS_IP or
ROS_HOSTNAME), a launched system listens on 127.0.0.1 only. roscpp's rosout and robot_state_publisher bind their
TCPROS data port to every interface whatever ROS_IP says: they are reported, not hidden (docs/real_robot.md: several
machines)."""

import os
import pathlib
import socket
import subprocess

from ros_processes import Processes, start_roscore, wait_until

ROSCPP = ("rosout", "robot_state_pu")  # process names (comm, 15 characters) of the roscpp nodes of sim.launch
LOOPBACK = ("127.0.0.1", "[::1]", "[::ffff:127.0.0.1]")


def descendants(pid):
    """pid and every process below it (Linux /proc)."""
    found, frontier = {pid}, [pid]
    while frontier:
        children = pathlib.Path(f"/proc/{frontier.pop()}/task")
        for task in children.glob("*/children") if children.is_dir() else []:
            for child in task.read_text().split():
                if int(child) not in found:
                    found.add(int(child))
                    frontier.append(int(child))
    return found


def listening(pids):
    """(process name, local address, port) of every listening TCP socket of the processes (Linux /proc: no tools)."""
    inodes = {}
    for pid in pids:
        name = (
            pathlib.Path(f"/proc/{pid}/comm").read_text().strip() if pathlib.Path(f"/proc/{pid}/comm").exists() else ""
        )
        for fd in pathlib.Path(f"/proc/{pid}/fd").glob("*"):
            try:
                target = os.readlink(fd)
            except OSError:
                continue
            if target.startswith("socket:["):
                inodes[target[8:-1]] = name
    sockets = []
    for table, width in (("/proc/net/tcp", 8), ("/proc/net/tcp6", 32)):
        for line in pathlib.Path(table).read_text().splitlines()[1:]:
            fields = line.split()
            local, state, inode = fields[1], fields[3], fields[9]
            if state != "0A" or inode not in inodes:  # 0A: LISTEN
                continue
            address, port = local.split(":")
            sockets.append((inodes[inode], decode(address, width), int(port, 16)))
    return sockets


def decode(address, width):
    """The text form of a /proc/net/tcp address: 4 (IPv4) or 16 (IPv6) bytes, each 32-bit word little-endian."""
    raw = b"".join(bytes.fromhex(address[i : i + 8])[::-1] for i in range(0, width, 8))
    if len(raw) == 4:
        return socket.inet_ntop(socket.AF_INET, raw)
    text = socket.inet_ntop(socket.AF_INET6, raw)
    return f"[{text}]"


def nodes(env):
    """The node names the master knows."""
    return set(subprocess.run(["rosnode", "list"], env=env, capture_output=True, text=True).stdout.split())


def test_a_launched_system_listens_on_loopback_only(tmp_path):
    with Processes(tmp_path) as processes:
        assert processes.env.get("ROS_IP") or processes.env.get("ROS_HOSTNAME"), "build/env.sh sets ROS_IP"
        start_roscore(processes)
        launch = processes.start("sim", ["roslaunch", "teleteach", "sim.launch", "real_time_factor:=0"])
        wait_until(lambda: {"/robot_sim", "/skill_server"} <= nodes(processes.env), 120, "robot_sim and skill_server")
        core = processes.process("roscore")
        sockets = listening(descendants(core.pid) | descendants(launch.pid))
        names = {name for name, _, _ in sockets}
        # Expect: the master, roslaunch and the Python nodes listen, on loopback only
        assert "rosmaster" in names and len(names) >= 4, sockets
        exposed = [entry for entry in sockets if entry[1] not in LOOPBACK and not entry[0].startswith(ROSCPP)]
        assert exposed == [], f"listening beyond loopback: {exposed} (all: {sockets})"
        print("roscpp nodes on all interfaces:", [entry for entry in sockets if entry[1] not in LOOPBACK])
