"""Four OpenGL views of the stiffness ellipsoid (thesis II-C): 3D, X-Y, Y-Z and X-Z, in one QOpenGLWidget.

Fixed-function OpenGL through PyOpenGL; a lit unit sphere is scaled by the semi-axes and rotated by R, the
principal axes are drawn on top and labelled (stiffness [N/m] and angle) with a QPainter overlay.
"""

import logging
import math

import numpy as np
from OpenGL import GL
from PyQt5.QtCore import QPointF, QRectF, Qt
from PyQt5.QtGui import QColor, QFont, QPainter
from PyQt5.QtWidgets import QOpenGLWidget

from teleteach.core.rotations import rpy_to_matrix
from teleteach.gui.ellipsoid import EllipsoidCommand

LOG = logging.getLogger(__name__)
AXIS_COLOURS = ((0.85, 0.1, 0.1), (0.1, 0.65, 0.1), (0.15, 0.3, 0.95))
LABEL_BACKGROUND = QColor(255, 255, 255, 225)  # behind every label: readable on the ellipsoid as on the background
AXIS_NAMES = ("X", "Y", "Z")
ANGLE_NAMES = ("roll", "pitch", "yaw")


def _look_from(eye) -> np.ndarray:
    """Rows: screen right, screen up, towards the viewer, for a camera at direction ``eye`` with Z up."""
    out = np.asarray(eye, dtype=float) / np.linalg.norm(eye)
    right = np.cross([0.0, 0.0, 1.0], out)
    right /= np.linalg.norm(right)
    return np.array([right, np.cross(out, right), out])


# (title, world -> view rotation, position in the 2x2 grid: column, row from the top)
VIEWS = (
    ("3D", _look_from((1.0, 0.8, 0.7)), 0, 0),
    ("X-Y plane (top)", np.eye(3), 1, 0),
    ("Y-Z plane (front)", np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), 0, 1),
    ("X-Z plane (side)", np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]), 1, 1),
)


def sphere_mesh(stacks: int = 16, slices: int = 32):
    """Vertices (also the normals) and triangle indices of the unit sphere."""
    theta = np.linspace(0.0, math.pi, stacks + 1)
    phi = np.linspace(0.0, 2.0 * math.pi, slices + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    vertices = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)
    row = slices + 1
    quads = [
        (i * row + j, (i + 1) * row + j, (i + 1) * row + j + 1, i * row + j + 1)
        for i in range(stacks)
        for j in range(slices)
    ]
    indices = np.array([(a, b, c, a, c, d) for a, b, c, d in quads], dtype=np.uint32).reshape(-1)
    return vertices.astype(np.float32), indices


class EllipsoidView(QOpenGLWidget):
    """Draws :class:`EllipsoidCommand` in four viewports; repainted by the owner at a capped rate."""

    def __init__(self, command: EllipsoidCommand, parent=None):
        super().__init__(parent)
        self.command = command
        self.frames = 0
        self.errors = 0
        self._sphere = 0
        self._vertices, self._indices = sphere_mesh()
        self.setMinimumSize(480, 400)
        self.label_boxes = []  # (text, QRectF) of the axis labels of the last frame, in widget pixels

    def initializeGL(self) -> None:  # noqa: N802 - Qt's name
        """One-time GL state and the sphere's display list.

        No client arrays: PyOpenGL would have to find the current context to keep them alive, which fails
        intermittently under Qt.
        """
        GL.glClearColor(0.97, 0.97, 0.95, 1.0)
        self._sphere = GL.glGenLists(1)
        GL.glNewList(self._sphere, GL.GL_COMPILE)
        GL.glBegin(GL.GL_TRIANGLES)
        for vertex in self._vertices[self._indices]:
            GL.glNormal3fv(vertex)
            GL.glVertex3fv(vertex)
        GL.glEnd()
        GL.glEndList()

    def paintGL(self) -> None:  # noqa: N802 - Qt's name
        """Four views, then the labels; a GL error is logged, never raised into Qt (PyQt would abort)."""
        try:
            self._paint()
        except Exception as error:  # any GL failure: keep the GUI alive
            self.errors += 1
            if self.errors == 1 or self.errors % 100 == 0:
                LOG.error("ellipsoid view: drawing failed (%d times): %s", self.errors, error)

    def _paint(self) -> None:
        lengths, angles, _, _ = self.command.state()
        rotation = rpy_to_matrix(*angles)
        ratio = self.devicePixelRatioF()
        width, height = self.width() * ratio, self.height() * ratio
        half = self.command.config.max_pixels * 1.3
        self._reset_state()
        GL.glClear(GL.GL_COLOR_BUFFER_BIT | GL.GL_DEPTH_BUFFER_BIT)
        for _, view, column, row in VIEWS:
            x, y = int(column * width / 2), int((1 - row) * height / 2)
            w, h = int(width / 2), int(height / 2)
            GL.glViewport(x, y, w, h)
            aspect = w / max(1, h)
            GL.glMatrixMode(GL.GL_PROJECTION)
            GL.glLoadIdentity()
            GL.glOrtho(-half * aspect, half * aspect, -half, half, -4 * half, 4 * half)
            GL.glMatrixMode(GL.GL_MODELVIEW)
            GL.glLoadIdentity()
            GL.glLightfv(GL.GL_LIGHT0, GL.GL_POSITION, (0.4, 0.6, 1.0, 0.0))
            view4 = np.eye(4)
            view4[:3, :3] = view
            GL.glLoadMatrixd(view4.T.ravel())
            self._draw_frame(half)
            self._draw_ellipsoid(rotation, lengths)
            self._draw_axes(rotation, lengths)
        self._draw_labels(lengths, angles, rotation, width / ratio, height / ratio, half)
        self.frames += 1

    @staticmethod
    def _reset_state() -> None:
        # The QPainter overlay of the previous frame may leave its programs and buffers bound.
        GL.glUseProgram(0)
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, 0)
        GL.glBindBuffer(GL.GL_ELEMENT_ARRAY_BUFFER, 0)
        GL.glDisable(GL.GL_BLEND)
        GL.glDisable(GL.GL_SCISSOR_TEST)
        GL.glDisable(GL.GL_STENCIL_TEST)
        GL.glEnable(GL.GL_DEPTH_TEST)
        GL.glDepthMask(GL.GL_TRUE)
        GL.glEnable(GL.GL_LIGHT0)
        GL.glEnable(GL.GL_NORMALIZE)  # glScale would otherwise break the lighting normals
        GL.glEnable(GL.GL_COLOR_MATERIAL)
        GL.glLightModelfv(GL.GL_LIGHT_MODEL_AMBIENT, (0.35, 0.35, 0.35, 1.0))

    @staticmethod
    def _draw_frame(half: float) -> None:
        """Thin grey base-frame axes through the origin."""
        GL.glDisable(GL.GL_LIGHTING)
        GL.glLineWidth(1.0)
        GL.glColor3f(0.7, 0.7, 0.7)
        GL.glBegin(GL.GL_LINES)
        for axis in np.eye(3):
            GL.glVertex3dv(-half * axis)
            GL.glVertex3dv(half * axis)
        GL.glEnd()

    def _draw_ellipsoid(self, rotation: np.ndarray, lengths: np.ndarray) -> None:
        transform = np.eye(4)
        transform[:3, :3] = rotation @ np.diag(lengths)
        GL.glPushMatrix()
        GL.glMultMatrixd(transform.T.ravel())
        GL.glEnable(GL.GL_LIGHTING)
        GL.glColor3f(0.9, 0.35, 0.3)
        GL.glCallList(self._sphere)
        GL.glPopMatrix()

    @staticmethod
    def _draw_axes(rotation: np.ndarray, lengths: np.ndarray) -> None:
        """Principal axes on top of the surface, 15 % longer than the semi-axes."""
        GL.glDisable(GL.GL_LIGHTING)
        GL.glDisable(GL.GL_DEPTH_TEST)
        GL.glLineWidth(3.0)
        GL.glBegin(GL.GL_LINES)
        for axis in range(3):
            GL.glColor3f(*AXIS_COLOURS[axis])
            tip = 1.15 * lengths[axis] * rotation[:, axis]
            GL.glVertex3dv(-tip)
            GL.glVertex3dv(tip)
        GL.glEnd()
        GL.glEnable(GL.GL_DEPTH_TEST)

    def _draw_labels(self, lengths, angles, rotation, width, height, half) -> None:
        """View titles and, at each axis tip, its stiffness [N/m] (and angle in the 3D view)."""
        gain = self.command.config.stiffness_per_pixel
        self.label_boxes = []  # (text, box) drawn this frame, in widget pixels
        painter = QPainter(self)
        painter.setRenderHint(QPainter.TextAntialiasing)
        title_font = QFont(self.font())
        title_font.setBold(True)
        label_font = QFont(self.font())
        label_font.setPointSizeF(max(7.0, self.font().pointSizeF() - 1))
        painter.setPen(QColor(120, 120, 120))
        painter.drawLine(QPointF(width / 2, 0), QPointF(width / 2, height))
        painter.drawLine(QPointF(0, height / 2), QPointF(width, height / 2))
        for title, view, column, row in VIEWS:
            left, top, w, h = column * width / 2, row * height / 2, width / 2, height / 2
            painter.setFont(title_font)
            painter.setPen(QColor(40, 40, 40))
            painter.drawText(QRectF(left + 6, top + 4, w - 12, 20), Qt.AlignLeft, title)
            scale = (h / 2) / half
            painter.setFont(label_font)
            for axis in range(3):
                colour = QColor(*(int(255 * c * 0.8) for c in AXIS_COLOURS[axis]))
                painter.setPen(colour)
                if title == "3D":  # the full values as a legend: tip labels would collide in perspective
                    legend = (
                        f"{AXIS_NAMES[axis]}: {lengths[axis] * gain:.0f} N/m, "
                        f"{ANGLE_NAMES[axis]} {math.degrees(angles[axis]):.1f}\N{DEGREE SIGN}"
                    )
                    line = QRectF(left + 6, top + h - 62 + 18 * axis, w - 12, 18)
                    painter.fillRect(painter.boundingRect(line, Qt.AlignLeft, legend), LABEL_BACKGROUND)
                    painter.drawText(line, Qt.AlignLeft, legend)
                tip = view @ (1.15 * lengths[axis] * rotation[:, axis])
                if abs(tip[0]) + abs(tip[1]) < 0.2 * lengths[axis]:
                    continue  # axis points at the viewer: its label would cover the centre
                text = AXIS_NAMES[axis] if title == "3D" else f"{AXIS_NAMES[axis]} {lengths[axis] * gain:.0f} N/m"
                half_width = 8 if title == "3D" else 60
                direction = np.array([tip[0], -tip[1]]) / math.hypot(tip[0], tip[1])
                # the text's box sits just beyond the tip, so the axis line does not run through it
                centre = np.array([left + w / 2 + tip[0] * scale, top + h / 2 - tip[1] * scale])
                centre += direction * np.array([half_width + 4, 13])
                box = QRectF(centre[0] - half_width, centre[1] - 9, 2 * half_width, 18)
                box.moveLeft(min(max(box.left(), left + 2), left + w - 2 - box.width()))
                box.moveTop(min(max(box.top(), top + 22), top + h - 20))
                # a label held inside the view may land on the ellipsoid, whose X axis is as red as its text
                used = painter.boundingRect(box, Qt.AlignCenter, text).adjusted(-3, 0, 3, 0)
                painter.fillRect(used, LABEL_BACKGROUND)
                painter.drawText(box, Qt.AlignCenter, text)
                self.label_boxes.append((text, used))
        painter.end()
