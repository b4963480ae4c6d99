"""What the GUI perceives while it teaches at a place: the scene (teleteach/scene) and the base in the world (TF).

Heard only in LOW-LEVEL and a tab whose adapter ``hears_scene`` (TELEOP): the gap a target-frame trajectory places
at, the gap nearest a taught path's end, the opening the placement's assistance guides into.
"""

import threading
from typing import Optional, Tuple

import numpy as np
import rospy
import tf2_ros
from visualization_msgs.msg import MarkerArray

from teleteach.core.frames import Transform
from teleteach.core.observed import WORLD_FRAME, ObservedScene, observed_from_markers


class Perception:
    """teleteach/scene and TF world -> ``base_frame`` while ``listen(True)``; thread-safe readers."""

    def __init__(self, base_frame: str):
        self.base_frame = base_frame
        self._lock = threading.Lock()
        self._scene: Optional[ObservedScene] = None
        self._subscriber: Optional[rospy.Subscriber] = None
        self._tf_buffer: Optional[tf2_ros.Buffer] = None
        self._tf_listener: Optional[tf2_ros.TransformListener] = None

    def listen(self, teaching: bool) -> None:
        """Hear the perceived scene and TF (``teaching``), or stop and forget the scene (worker thread)."""
        if teaching and self._subscriber is None:
            self._tf_buffer = tf2_ros.Buffer(cache_time=rospy.Duration(10.0))
            self._tf_listener = tf2_ros.TransformListener(self._tf_buffer)
            self._subscriber = rospy.Subscriber("teleteach/scene", MarkerArray, self._on_scene, queue_size=1)
        elif not teaching and self._subscriber is not None:
            self._subscriber.unregister()
            self._subscriber = None
            self._tf_listener.unregister()
            self._tf_buffer = self._tf_listener = None
            with self._lock:
                self._scene = None

    def _on_scene(self, message: MarkerArray) -> None:
        scene, _ = observed_from_markers(message.markers)
        with self._lock:
            self._scene = scene

    def scene(self) -> Optional[ObservedScene]:
        """What perception reports (teleteach/scene), heard in LOW-LEVEL and TELEOP; None before it or elsewhere."""
        with self._lock:
            return self._scene

    def target_in_base(self, gap: str) -> Tuple[Optional[Transform], str]:
        """base_link <- the perceived gap's frame, or (None, why not): needs the gap perceived and the base in TF."""
        scene = self.scene()
        if scene is None:
            return None, "no perception yet (teleteach/scene)"
        if gap not in scene.gaps:
            return None, f"perception reports no {gap} (it reports {', '.join(sorted(scene.gaps)) or 'no gaps'})"
        base, why = self.base_in_world()
        if base is None:
            return None, why
        return base.inverse() * scene.gaps[gap].frame, ""

    def base_in_world(self) -> Tuple[Optional[Transform], str]:
        """The base frame in world (TF world -> base_frame, heard in LOW-LEVEL and TELEOP), or (None, why not)."""
        buffer = self._tf_buffer
        if buffer is None:
            return None, "not in LOW-LEVEL or TELEOP"
        try:
            stamped = buffer.lookup_transform(WORLD_FRAME, self.base_frame, rospy.Time(0))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException) as error:
            return None, f"no transform {WORLD_FRAME} -> {self.base_frame}: {error}"
        t, r = stamped.transform.translation, stamped.transform.rotation
        return Transform.from_pose([t.x, t.y, t.z, r.x, r.y, r.z, r.w]), ""

    def nearest_gap(self, point) -> Tuple[Optional[str], Optional[Transform], str]:
        """The perceived gap whose origin is nearest ``point`` (base_link), its pose in base_link, or why none."""
        scene = self.scene()
        if scene is None or not scene.gaps:
            return None, None, "no perception yet (teleteach/scene)" if scene is None else "perception reports no gaps"
        found = []
        for gap in sorted(scene.gaps):
            target, why = self.target_in_base(gap)
            if target is None:
                return None, None, why
            found.append((float(np.linalg.norm(target.position - np.asarray(point))), gap, target))
        _, gap, target = min(found, key=lambda entry: entry[0])
        return gap, target, ""
