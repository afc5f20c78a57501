"""Rigid transforms as immutable values, and the plain-float math behind them.

A :class:`Transform` is a rotation followed by a translation: it maps a point
``p`` expressed in a child frame to ``R p + t`` in its parent frame (the child's
pose in the parent, as in a tf2 ``geometry_msgs/Transform``). Quaternions are
``(x, y, z, w)`` as in ROS and scipy.

Internally a transform is a tuple of seven Python floats ``(x, y, z, qx, qy,
qz, qw)``; the helpers ``_compose``, ``_inverse``, ``_inv_compose`` and
``_interpolate`` work on those tuples with :mod:`math` only, which is what makes
buffer lookups cost microseconds instead of tens of microseconds. numpy arrays
are built only at the API boundary (``.translation``, ``.rotation``,
``to_matrix()``, ``apply_point()`` ...), lazily and once per object.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .errors import InvalidArgumentException

_isfinite = math.isfinite
_sqrt = math.sqrt
_fabs = math.fabs
_acos = math.acos
_sin = math.sin

#: Relative tolerance on a quaternion's norm accepted (and normalised) on construction.
QUAT_NORM_TOLERANCE = 0.01

Tuple7 = tuple[float, float, float, float, float, float, float]
IDENTITY7: Tuple7 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


# --------------------------------------------------------------------------------------
# plain-float kernels on 7-tuples (x, y, z, qx, qy, qz, qw)
# --------------------------------------------------------------------------------------

def _compose(a: Tuple7, b: Tuple7) -> Tuple7:
    """a * b: apply b first, then a."""
    ax, ay, az, qx, qy, qz, qw = a
    bx, by, bz, rx, ry, rz, rw = b
    # rotate b's translation by a's quaternion: v' = v + w*t + u x t, t = 2 u x v
    tx = 2.0 * (qy * bz - qz * by)
    ty = 2.0 * (qz * bx - qx * bz)
    tz = 2.0 * (qx * by - qy * bx)
    return (ax + bx + qw * tx + (qy * tz - qz * ty),
            ay + by + qw * ty + (qz * tx - qx * tz),
            az + bz + qw * tz + (qx * ty - qy * tx),
            qw * rx + qx * rw + qy * rz - qz * ry,
            qw * ry - qx * rz + qy * rw + qz * rx,
            qw * rz + qx * ry - qy * rx + qz * rw,
            qw * rw - qx * rx - qy * ry - qz * rz)


def _inverse(a: Tuple7) -> Tuple7:
    """The inverse transform: (-R^T t, q*)."""
    x, y, z, qx, qy, qz, qw = a
    # rotate -t by the conjugate quaternion (-qx, -qy, -qz, qw)
    nx, ny, nz = -x, -y, -z
    tx = 2.0 * (-qy * nz + qz * ny)
    ty = 2.0 * (-qz * nx + qx * nz)
    tz = 2.0 * (-qx * ny + qy * nx)
    return (nx + qw * tx + (-qy * tz + qz * ty),
            ny + qw * ty + (-qz * tx + qx * tz),
            nz + qw * tz + (-qx * ty + qy * tx),
            -qx, -qy, -qz, qw)


def _inv_compose(a: Tuple7, b: Tuple7) -> Tuple7:
    """a.inverse() * b, fused: (R_a^T (t_b - t_a), q_a* q_b)."""
    ax, ay, az, qx, qy, qz, qw = a
    bx, by, bz, rx, ry, rz, rw = b
    vx, vy, vz = bx - ax, by - ay, bz - az
    # rotate v by conjugate (-qx, -qy, -qz, qw)
    tx = 2.0 * (-qy * vz + qz * vy)
    ty = 2.0 * (-qz * vx + qx * vz)
    tz = 2.0 * (-qx * vy + qy * vx)
    return (vx + qw * tx + (-qy * tz + qz * ty),
            vy + qw * ty + (-qz * tx + qx * tz),
            vz + qw * tz + (-qx * ty + qy * tx),
            qw * rx - qx * rw - qy * rz + qz * ry,
            qw * ry + qx * rz - qy * rw - qz * rx,
            qw * rz - qx * ry + qy * rx - qz * rw,
            qw * rw + qx * rx + qy * ry + qz * rz)


#: Above this |<q0, q1>| (relative angle below ~3e-5 rad) SLERP is computed as a
#: normalised lerp, which then agrees with SLERP to ~1e-15.
SLERP_NLERP_DOT = 1.0 - 1e-10


def _interpolate(a: Tuple7, b: Tuple7, s: float) -> Tuple7:
    """Linear translation, shortest-path SLERP rotation; s in [0, 1]."""
    ax, ay, az, p0, p1, p2, p3 = a
    bx, by, bz, q0, q1, q2, q3 = b
    d = p0 * q0 + p1 * q1 + p2 * q2 + p3 * q3
    if d < 0.0:  # q and -q are the same rotation: take the short way round
        d = -d
        q0 = -q0
        q1 = -q1
        q2 = -q2
        q3 = -q3
    if d < SLERP_NLERP_DOT:
        th = _acos(d)
        si = 1.0 / _sin(th)
        k0 = _sin((1.0 - s) * th) * si
        k1 = _sin(s * th) * si
        return (ax + (bx - ax) * s, ay + (by - ay) * s, az + (bz - az) * s,
                k0 * p0 + k1 * q0, k0 * p1 + k1 * q1, k0 * p2 + k1 * q2, k0 * p3 + k1 * q3)
    w0 = p0 + (q0 - p0) * s
    w1 = p1 + (q1 - p1) * s
    w2 = p2 + (q2 - p2) * s
    w3 = p3 + (q3 - p3) * s
    n = 1.0 / _sqrt(w0 * w0 + w1 * w1 + w2 * w2 + w3 * w3)
    return (ax + (bx - ax) * s, ay + (by - ay) * s, az + (bz - az) * s,
            w0 * n, w1 * n, w2 * n, w3 * n)


def _matrix3(qx: float, qy: float, qz: float, qw: float) -> tuple[tuple[float, ...], ...]:
    """Rotation matrix rows of a unit quaternion."""
    xx, yy, zz = qx * qx, qy * qy, qz * qz
    xy, xz, yz = qx * qy, qx * qz, qy * qz
    wx, wy, wz = qw * qx, qw * qy, qw * qz
    return ((1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy)),
            (2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx)),
            (2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy)))


def _quat_from_matrix3(m) -> tuple[float, float, float, float]:
    """Shepperd's method; returns a unit quaternion with w >= 0."""
    m00, m01, m02 = float(m[0][0]), float(m[0][1]), float(m[0][2])
    m10, m11, m12 = float(m[1][0]), float(m[1][1]), float(m[1][2])
    m20, m21, m22 = float(m[2][0]), float(m[2][1]), float(m[2][2])
    tr = m00 + m11 + m22
    if tr > 0.0:
        s = _sqrt(tr + 1.0) * 2.0
        w, x, y, z = 0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s
    elif m00 > m11 and m00 > m22:
        s = _sqrt(1.0 + m00 - m11 - m22) * 2.0
        w, x, y, z = (m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s
    elif m11 > m22:
        s = _sqrt(1.0 + m11 - m00 - m22) * 2.0
        w, x, y, z = (m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s
    else:
        s = _sqrt(1.0 + m22 - m00 - m11) * 2.0
        w, x, y, z = (m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s
    n = _sqrt(x * x + y * y + z * z + w * w)
    if w < 0.0:
        n = -n
    return x / n, y / n, z / n, w / n


def _quat_from_euler(yaw: float, pitch: float, roll: float) -> tuple[float, float, float, float]:
    """q = qz(yaw) * qy(pitch) * qx(roll), i.e. R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cy, sy = math.cos(0.5 * yaw), math.sin(0.5 * yaw)
    cp, sp = math.cos(0.5 * pitch), math.sin(0.5 * pitch)
    cr, sr = math.cos(0.5 * roll), math.sin(0.5 * roll)
    return (sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy)


#: |cos(pitch)| below this is treated as gimbal lock by yaw_pitch_roll() / yaw_only().
GIMBAL_EPS = 1e-9


def _euler_from_quat(qx: float, qy: float, qz: float, qw: float) -> tuple[float, float, float]:
    """(yaw, pitch, roll) with R = Rz(yaw) Ry(pitch) Rx(roll); pitch in [-pi/2, pi/2].

    At gimbal lock (pitch = +-90 deg) roll is set to 0 and the rest is yaw.
    """
    (r00, r01, _r02), (r10, r11, _r12), (r20, r21, r22) = _matrix3(qx, qy, qz, qw)
    c = math.hypot(r00, r10)
    pitch = math.atan2(-r20, c)
    if c > GIMBAL_EPS:
        return math.atan2(r10, r00), pitch, math.atan2(r21, r22)
    return math.atan2(-r01, r11), pitch, 0.0


def euler_from_quaternion(q: Any) -> tuple[float, float, float]:
    """(roll, pitch, yaw) of an (x, y, z, w) quaternion, R = Rz(yaw) Ry(pitch) Rx(roll).

    tf.transformations' name and order (the lab's `euler_from_quaternion`); the
    quaternion is normalised first. The one quaternion->Euler conversion of the project.
    """
    qx, qy, qz, qw = (float(v) for v in q)
    n = _sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if not n > 0.0 or not _isfinite(n):
        raise InvalidArgumentException(f"cannot take Euler angles of quaternion {tuple(q)!r}")
    yaw, pitch, roll = _euler_from_quat(qx / n, qy / n, qz / n, qw / n)
    return roll, pitch, yaw


def quaternion_from_euler(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of R = Rz(yaw) Ry(pitch) Rx(roll); tf.transformations' name and order."""
    return _quat_from_euler(yaw, pitch, roll)


def quaternion_slerp(q0: Any, q1: Any, s: float) -> tuple[float, float, float, float]:
    """Shortest-path SLERP between (x, y, z, w) unit quaternions; s = 0 gives q0, 1 gives q1."""
    a = (0.0, 0.0, 0.0, *(float(v) for v in q0))
    b = (0.0, 0.0, 0.0, *(float(v) for v in q1))
    return _interpolate(a, b, float(s))[3:]  # type: ignore[return-value]


# --------------------------------------------------------------------------------------
# validation
# --------------------------------------------------------------------------------------

def _as_floats(value: Any, n: int, what: str) -> tuple[float, ...]:
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError) as e:
        raise InvalidArgumentException(f"{what} must be {n} numbers, got {value!r}") from e
    if len(out) != n:
        raise InvalidArgumentException(f"{what} must have {n} elements, got {len(out)}: {value!r}")
    for v in out:
        if not _isfinite(v):
            raise InvalidArgumentException(f"{what} must be finite (no NaN/inf), got {out}")
    return out


def _checked_quat(q: tuple[float, ...], what: str = "rotation") -> tuple[float, float, float, float]:
    """Accept a quaternion whose norm is within 1 % of 1 and normalise it."""
    qx, qy, qz, qw = q
    n = _sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if _fabs(n - 1.0) > QUAT_NORM_TOLERANCE:
        raise InvalidArgumentException(
            f"{what} quaternion (x, y, z, w) = {tuple(q)} has norm {n:.6g}; "
            f"must be within {QUAT_NORM_TOLERANCE:.0%} of 1")
    if n != 1.0:
        qx, qy, qz, qw = qx / n, qy / n, qz / n, qw / n
    return qx, qy, qz, qw


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


_CHUNK = 8192  # rows per block for batched apply_point (192 KiB: stays in cache)


def _rotate_translate(a: np.ndarray, rt: np.ndarray, t: np.ndarray | None) -> np.ndarray:
    """a @ rt (+ t unless None) for an (N, 3) float64 array, into a new array.

    One big matmul followed by ``+= t`` streams the whole result through memory
    twice, and numpy's broadcast over an inner axis of length 3 is a short strided
    loop. Working in cache-sized blocks (matmul into the block, then add the
    translation tiled to the block's flat length) keeps the second pass in cache.
    Blocks also stay below OpenBLAS's threading threshold: one (1e6, 3) matmul
    wakes BLAS threads, which on a loaded 2-core machine made it 20x slower and
    erratic; single-threaded blocks are steady.
    """
    n = a.shape[0]
    out = np.empty((n, 3))
    if n <= _CHUNK:
        np.matmul(a, rt, out=out)
        if t is not None:
            out += t
        return out
    flat = out.reshape(-1)
    matmul = np.matmul
    stop = n - n % _CHUNK
    if t is None:
        for i in range(0, stop, _CHUNK):
            matmul(a[i:i + _CHUNK], rt, out=out[i:i + _CHUNK])
    else:
        tile = np.tile(t, _CHUNK)
        for i in range(0, stop, _CHUNK):
            j = i + _CHUNK
            matmul(a[i:j], rt, out=out[i:j])
            flat[3 * i:3 * j] += tile
    if stop < n:
        matmul(a[stop:], rt, out=out[stop:])
        if t is not None:
            out[stop:] += t
    return out


# --------------------------------------------------------------------------------------
# Transform
# --------------------------------------------------------------------------------------

_new = object.__new__
_setattr = object.__setattr__


class Transform:
    """An immutable rigid transform: rotation ``rotation`` then translation ``translation``.

    ``Transform(translation=(x, y, z), rotation=(qx, qy, qz, qw))``. NaN/inf or a
    quaternion norm more than 1 % away from 1 raise :class:`InvalidArgumentException`;
    within 1 % the quaternion is normalised. ``a * b`` applies ``b`` first, then ``a``.
    Equality is exact on the stored floats (use :meth:`almost_equal` for tolerance,
    which also treats q and -q as the same rotation).
    """

    __slots__ = ("_v", "_t", "_q", "_r")

    def __init__(self, translation: Any = (0.0, 0.0, 0.0),
                 rotation: Any = (0.0, 0.0, 0.0, 1.0)) -> None:
        # fast path: unpack 3 + 4 numbers, one isfinite each, one norm check
        if type(translation) is np.ndarray:
            translation = translation.tolist()
        if type(rotation) is np.ndarray:
            rotation = rotation.tolist()
        try:
            x, y, z = translation
            qx, qy, qz, qw = rotation
            x = float(x)
            y = float(y)
            z = float(z)
            qx = float(qx)
            qy = float(qy)
            qz = float(qz)
            qw = float(qw)
        except (TypeError, ValueError):
            t = _as_floats(translation, 3, "translation")  # raises the precise error
            q = _as_floats(rotation, 4, "rotation")
            raise InvalidArgumentException(f"invalid transform {t} {q}")  # pragma: no cover
        n2 = qx * qx + qy * qy + qz * qz + qw * qw
        if not (_isfinite(x) and _isfinite(y) and _isfinite(z) and _isfinite(n2)
                and 0.9801 <= n2 <= 1.0201 and n2 != 1.0):
            if n2 == 1.0 and _isfinite(x) and _isfinite(y) and _isfinite(z):
                _setattr(self, "_v", (x, y, z, qx, qy, qz, qw))
                return
            t = _as_floats((x, y, z), 3, "translation")
            q = _checked_quat(_as_floats((qx, qy, qz, qw), 4, "rotation"))
            _setattr(self, "_v", t + q)
            return
        n = _sqrt(n2)
        _setattr(self, "_v", (x, y, z, qx / n, qy / n, qz / n, qw / n))

    # fast internal constructor: no validation, for values computed from valid ones
    @classmethod
    def _of(cls, v: Tuple7) -> "Transform":
        obj = _new(cls)
        _setattr(obj, "_v", v)
        return obj

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError("Transform is immutable")

    def __delattr__(self, name: str) -> None:
        raise AttributeError("Transform is immutable")

    def __reduce__(self):
        return (Transform, (self._v[:3], self._v[3:]))

    # ---- constructors -------------------------------------------------------------
    @classmethod
    def identity(cls) -> "Transform":
        return cls._of(IDENTITY7)

    @classmethod
    def from_matrix(cls, m: Any, atol: float = 1e-5) -> "Transform":
        """From a 4x4 homogeneous matrix. The 3x3 block must be a rotation
        (orthonormal, det +1, to ``atol``) and the last row ``[0, 0, 0, 1]``."""
        a = np.asarray(m, dtype=float)
        if a.shape != (4, 4):
            raise InvalidArgumentException(f"from_matrix needs a 4x4 matrix, got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise InvalidArgumentException("from_matrix: matrix contains NaN/inf")
        if not np.allclose(a[3], (0.0, 0.0, 0.0, 1.0), atol=atol):
            raise InvalidArgumentException(f"from_matrix: last row must be [0, 0, 0, 1], got {a[3]}")
        r = a[:3, :3]
        if not np.allclose(r @ r.T, np.eye(3), atol=atol) or np.linalg.det(r) < 0:
            raise InvalidArgumentException("from_matrix: the 3x3 block is not a rotation matrix")
        q = _quat_from_matrix3(r)
        return cls._of((float(a[0, 3]), float(a[1, 3]), float(a[2, 3])) + q)

    @classmethod
    def from_euler(cls, *, yaw: float = 0.0, pitch: float = 0.0, roll: float = 0.0,
                   translation: Any = (0.0, 0.0, 0.0)) -> "Transform":
        """R = Rz(yaw) Ry(pitch) Rx(roll) (static_transform_publisher's order), radians.

        Keyword-only, so the order cannot be mistaken: tf.transformations'
        quaternion_from_euler(roll, pitch, yaw) takes the same angles roll-first.
        """
        e = _as_floats((yaw, pitch, roll), 3, "euler angles")
        t = _as_floats(translation, 3, "translation")
        return cls._of(t + _quat_from_euler(*e))

    # ---- accessors ----------------------------------------------------------------
    @property
    def translation(self) -> np.ndarray:
        """(3,) read-only float array."""
        try:
            return self._t
        except AttributeError:
            a = _readonly(np.array(self._v[:3]))
            _setattr(self, "_t", a)
            return a

    @property
    def rotation(self) -> np.ndarray:
        """(4,) read-only quaternion (x, y, z, w)."""
        try:
            return self._q
        except AttributeError:
            a = _readonly(np.array(self._v[3:]))
            _setattr(self, "_q", a)
            return a

    @property
    def xyz(self) -> tuple[float, float, float]:
        """Translation as a tuple of Python floats (no numpy)."""
        return self._v[:3]  # type: ignore[return-value]

    @property
    def xyzw(self) -> tuple[float, float, float, float]:
        """Quaternion as a tuple of Python floats (no numpy)."""
        return self._v[3:]  # type: ignore[return-value]

    def to_tuple(self) -> Tuple7:
        """(x, y, z, qx, qy, qz, qw) as Python floats."""
        return self._v

    def rotation_matrix(self) -> np.ndarray:
        """(3, 3) read-only rotation matrix."""
        try:
            return self._r
        except AttributeError:
            a = _readonly(np.array(_matrix3(*self._v[3:])))
            _setattr(self, "_r", a)
            return a

    def to_matrix(self) -> np.ndarray:
        """A new (4, 4) homogeneous matrix."""
        m = np.eye(4)
        m[:3, :3] = self.rotation_matrix()
        m[:3, 3] = self._v[:3]
        return m

    def yaw_pitch_roll(self) -> tuple[float, float, float]:
        """(yaw, pitch, roll) in radians, in that order as the name says, R = Rz(yaw) Ry(pitch) Rx(roll), pitch in
        [-pi/2, pi/2]. At pitch = +-90 deg (gimbal lock) roll is reported as 0."""
        return _euler_from_quat(*self._v[3:])

    # ---- algebra ------------------------------------------------------------------
    def __mul__(self, other: "Transform") -> "Transform":
        if not isinstance(other, Transform):
            return NotImplemented
        return Transform._of(_compose(self._v, other._v))

    def inverse(self) -> "Transform":
        return Transform._of(_inverse(self._v))

    def yaw_only(self) -> "Transform":
        """Same translation, roll and pitch removed, heading kept.

        The heading is the direction of the rotated x axis projected onto the
        horizontal (x-y) plane: ``yaw = atan2(R[1,0], R[0,0])``. At pitch exactly
        +-90 deg (x axis vertical, within ``GIMBAL_EPS``) that projection vanishes;
        then the heading follows :meth:`yaw_pitch_roll`'s convention (roll = 0, all the
        rotation about z is yaw), i.e. the direction of the rotated y axis turned by
        -90 deg. Near that singularity the heading is numerically ill-conditioned,
        as it is for any yaw extraction.
        """
        yaw = _euler_from_quat(*self._v[3:])[0]
        h = 0.5 * yaw
        return Transform._of(self._v[:3] + (0.0, 0.0, math.sin(h), math.cos(h)))

    def interpolate(self, other: "Transform", s: float) -> "Transform":
        """Linear translation, shortest-path SLERP rotation; s = 0 gives self, 1 gives other."""
        if s == 0.0:
            return self
        if s == 1.0:
            return other
        return Transform._of(_interpolate(self._v, other._v, float(s)))

    # ---- applying -----------------------------------------------------------------
    def apply_point(self, p: Any) -> np.ndarray:
        """R p + t for p of shape (3,) or (N, 3); returns a new float array."""
        return self._apply(p, True)

    def apply_vector(self, v: Any) -> np.ndarray:
        """R v (translation ignored) for v of shape (3,) or (N, 3)."""
        return self._apply(v, False)

    def _apply(self, p: Any, translate: bool) -> np.ndarray:
        x, y, z, qx, qy, qz, qw = self._v
        a = p if type(p) is np.ndarray else np.asarray(p, dtype=np.float64)
        if a.ndim == 1 and a.shape[0] == 3:
            px, py, pz = a.tolist()
            tx = 2.0 * (qy * pz - qz * py)
            ty = 2.0 * (qz * px - qx * pz)
            tz = 2.0 * (qx * py - qy * px)
            rx = px + qw * tx + (qy * tz - qz * ty)
            ry = py + qw * ty + (qz * tx - qx * tz)
            rz = pz + qw * tz + (qx * ty - qy * tx)
            if translate:
                return np.array((rx + x, ry + y, rz + z))
            return np.array((rx, ry, rz))
        if a.ndim != 2 or a.shape[1] != 3:
            raise InvalidArgumentException(f"expected shape (3,) or (N, 3), got {a.shape}")
        if a.dtype != np.float64:
            a = a.astype(np.float64)
        return _rotate_translate(a, self.rotation_matrix().T, self.translation if translate else None)

    # ---- comparisons --------------------------------------------------------------
    def almost_equal(self, other: "Transform", atol: float = 1e-9) -> bool:
        """Translations within atol and rotations equal up to q/-q within atol."""
        a, b = self._v, other._v
        if any(_fabs(a[i] - b[i]) > atol for i in range(3)):
            return False
        sign = 1.0 if sum(a[i] * b[i] for i in range(3, 7)) >= 0.0 else -1.0
        return all(_fabs(a[i] - sign * b[i]) <= atol for i in range(3, 7))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Transform):
            return NotImplemented
        return self._v == other._v

    def __hash__(self) -> int:
        return hash(self._v)

    def __repr__(self) -> str:
        x, y, z, qx, qy, qz, qw = self._v
        return (f"Transform(translation=({x:.6g}, {y:.6g}, {z:.6g}), "
                f"rotation=({qx:.6g}, {qy:.6g}, {qz:.6g}, {qw:.6g}))")


__all__ = ["Transform", "QUAT_NORM_TOLERANCE", "GIMBAL_EPS"]
