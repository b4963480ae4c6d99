"""State constraints of the trajectory optimisation (eq. 9b): a box boundary and a straight-edge obstacle.

The same geometry checks every state the loop outputs and gives the safe fallback its nearest free point.
"""

import dataclasses
import math
from typing import List, Optional

import numpy as np


@dataclasses.dataclass(frozen=True)
class Box:
    """Boundary x_min <= x <= x_max in the task plane [m]."""

    x_min: float
    y_min: float
    x_max: float
    y_max: float

    def __post_init__(self):
        values = (self.x_min, self.y_min, self.x_max, self.y_max)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"box bounds must be finite, got {values}")
        if self.x_min >= self.x_max or self.y_min >= self.y_max:
            raise ValueError(f"box must have x_min < x_max and y_min < y_max, got {values}")

    def as_array(self) -> np.ndarray:
        """(x_min, y_min, x_max, y_max) as the trajectory optimisation's parameter."""
        return np.array([self.x_min, self.y_min, self.x_max, self.y_max], dtype=float)


@dataclasses.dataclass(frozen=True)
class StraightEdge:
    """A straight edge through (x, y) [m]; the free side is along [cos yaw, sin yaw] (yaw [rad]).

    d(x) = (x - p) . [cos yaw, sin yaw] is the signed distance: positive on the free side (the paper's d(x, nu)).
    """

    x: float
    y: float
    yaw: float

    def __post_init__(self):
        if not all(math.isfinite(v) for v in (self.x, self.y, self.yaw)):
            raise ValueError(f"obstacle pose must be finite, got {(self.x, self.y, self.yaw)}")

    @property
    def normal(self) -> np.ndarray:
        """Unit normal pointing to the free side."""
        return np.array([math.cos(self.yaw), math.sin(self.yaw)])

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance of points (2 x n) to the edge."""
        return self.normal @ (np.asarray(points, dtype=float).reshape(2, -1) - np.array([[self.x], [self.y]]))

    def as_array(self) -> np.ndarray:
        """(px, py, yaw, active) as the trajectory optimisation's parameter."""
        return np.array([self.x, self.y, self.yaw, 1.0])


INACTIVE_OBSTACLE = np.array([0.0, 0.0, 0.0, 0.0])


def violations(points: np.ndarray, box: Box, obstacle: Optional[StraightEdge], margin: float = 0.0) -> np.ndarray:
    """Constraint violation [m] of each of the points (2 x n) against the box and obstacle shrunk by ``margin``.

    0 for a point inside, inf for a non-finite one.
    """
    points = np.asarray(points, dtype=float).reshape(2, -1)
    worst = np.max(
        [
            box.x_min + margin - points[0],
            points[0] - box.x_max + margin,
            box.y_min + margin - points[1],
            points[1] - box.y_max + margin,
        ],
        axis=0,
    )
    if obstacle is not None:
        worst = np.maximum(worst, margin - obstacle.distance(points))
    worst = np.maximum(worst, 0.0)
    worst[~np.all(np.isfinite(points), axis=0)] = math.inf
    return worst


def violation(points: np.ndarray, box: Box, obstacle: Optional[StraightEdge], margin: float = 0.0) -> float:
    """Largest constraint violation [m] of points (2 x n) against the box and obstacle shrunk by ``margin``."""
    return float(np.max(violations(points, box, obstacle, margin), initial=0.0))


def free_polygon(box: Box, obstacle: Optional[StraightEdge], margin: float) -> List[np.ndarray]:
    """Vertices of the free region (box shrunk by margin, cut by the obstacle's half-plane), empty if none."""
    lo = np.array([box.x_min + margin, box.y_min + margin])
    hi = np.array([box.x_max - margin, box.y_max - margin])
    if np.any(lo > hi):
        return []
    vertices = [lo, np.array([hi[0], lo[1]]), hi, np.array([lo[0], hi[1]])]
    if obstacle is None:
        return vertices
    # Sutherland-Hodgman clipping of the rectangle by d(x) >= margin; a vertex on the edge is its own crossing point.
    clipped = []
    for k, current in enumerate(vertices):
        previous = vertices[k - 1]
        d_current = float(obstacle.distance(current)[0]) - margin
        d_previous = float(obstacle.distance(previous)[0]) - margin
        if d_current >= 0:
            if d_previous < 0 < d_current:
                clipped.append(previous + (current - previous) * d_previous / (d_previous - d_current))
            clipped.append(current)
        elif d_previous > 0:
            clipped.append(previous + (current - previous) * d_previous / (d_previous - d_current))
    return clipped


def stopped_at_constraints(points: np.ndarray, box: Box, obstacle: Optional[StraightEdge], margin: float) -> np.ndarray:
    """Points (2 x n) as the robot, which stops at the constraints, would follow them.

    Each point outside the free region moves to its nearest free point; none moves when there is no free region.
    """
    points = np.array(points, dtype=float).reshape(2, -1)
    for index in np.flatnonzero(violations(points, box, obstacle, margin) > 0.0):
        free = nearest_free_point(points[:, index], box, obstacle, margin)
        if free is None:
            break
        points[:, index] = free
    return points


def nearest_free_point(
    point: np.ndarray, box: Box, obstacle: Optional[StraightEdge], margin: float
) -> Optional[np.ndarray]:
    """Closest point to ``point`` in the free region (exact projection onto a convex polygon), None if empty."""
    point = np.asarray(point, dtype=float)
    polygon = free_polygon(box, obstacle, margin)
    if not polygon:
        return None
    if np.all(np.isfinite(point)) and violation(point, box, obstacle, margin) == 0.0:
        return point.copy()
    if not np.all(np.isfinite(point)):
        return np.mean(polygon, axis=0)
    best, best_distance = None, math.inf
    for k, end in enumerate(polygon):
        start = polygon[k - 1]
        edge = end - start
        length2 = float(edge @ edge)
        fraction = 0.0 if length2 == 0 else float(np.clip((point - start) @ edge / length2, 0.0, 1.0))
        candidate = start + fraction * edge
        distance = float(np.linalg.norm(candidate - point))
        if distance < best_distance:
            best, best_distance = candidate, distance
    return best
