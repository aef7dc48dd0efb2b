"""The series and the effect terms of the closed loop, as arrays.

A *series* is what a shop records over many fixture cycles: for cycle k its measured
deviations y_k (one per model dimension, NaN where absent), the time it was machined,
the register changes in effect at that time (every corrections-log row with timestamp
≤ t_k), the parts cut by each tool since its last change and the temperatures.

The declared process model of Stryczek (2014, eqs. 3–4) says

    y_k = (s + u_k) · C + e_k                                   (closed-loop form)

with C the composite register → dimension matrix, s the unknown setup state and u_k
the applied corrections.  An *effect* the model lacks adds a term β · z_k(q) on a
covariate field z of shape (n_cycles, n_dimensions); :func:`effect_field` builds that
field for every kind of ``../shared/spec/cli-json.md`` (drift, thermal, wear, scale,
position, relation, group, level, process) so that the simulator, the diagnosis and
the forecast use one definition.

A *level* is a step at a cycle (a tool change, a new batch of stock, a process
change): z_k = 1[t_k ≥ t_step] · C[i] (one register) or · c_T (every tool alike).  A
*process* effect is a recorded process variable x (any channel of a process log: spindle
speed, stick-out, feed, warm-up minutes, a categorical level as a 0/1 indicator) acting
on one register, z_k = (x_k − x_ref) · C[i], or on every tool alike (· c_T); a variable
acting on a set of registers with a coefficient each is one process effect per register.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from setupfix.correction.relation import relation_matrices
from setupfix.model import ProcessModel
from setupfix.model.effects import EFFECT_KINDS

__all__ = [
    "KINDS",
    "Layout",
    "Series",
    "EffectSpec",
    "effect_field",
    "field_factors",
    "common_tool_row",
    "register_row",
    "channel_values",
    "PRODUCT",
]

Array = npt.NDArray[np.float64]

#: Effect kinds of the diagnose contract, in the order candidates are listed (the kinds a model may declare).
KINDS: tuple[str, ...] = EFFECT_KINDS

AXES = ("x", "y", "z")


@dataclass(frozen=True)
class Layout:
    """The static side of a process model, as arrays.

    Attributes
    ----------
    composite : ndarray of shape (n_registers, n_dimensions)
        C = [R_WF R_FD ; R_TF R_FD] (eqs. 3–4).
    register_ids, dimension_ids : tuple of str
    tools : ndarray of int
        Row indices of the tool registers in ``composite``.
    nominal, lower, upper : ndarray of shape (n_dimensions,) [model unit]
    coord : ndarray of shape (n_dimensions, 3) [model unit]
        Coordinate of each dimension, Σ_f R_FD[f, q] · position_f (NaN where unknown).
    groups : tuple of (str or None)
        Station / setup of each dimension.
    unit : str
    direction : ndarray of shape (n_dimensions, 3)
        Measuring direction n_q of each dimension of a multi-axis model (NaN where it has
        none: a one-axis model, a size, a position zone); empty for layouts built by hand.
    rotation : ndarray of shape (n_rotations, n_dimensions) [model unit / rad]
        Change of every dimension per radian of rotation of one WKS about the spindle axis
        through the WKS origin, Σ_f w_qf c_f n_q · (s × x_f) (:func:`rotation_rows`): the field
        of a ``rotation`` effect.  Only WKS of a multi-axis model whose features all have
        positions and that have no rotation register of their own.
    rotation_ids : tuple of str
        The WKS of each row of ``rotation``.
    spindle : str
        The spindle axis (``X``, ``Y`` or ``Z``).
    """

    composite: Array
    register_ids: tuple[str, ...]
    dimension_ids: tuple[str, ...]
    tools: npt.NDArray[np.intp]
    nominal: Array
    lower: Array
    upper: Array
    coord: Array
    groups: tuple[str | None, ...]
    unit: str = "mm"
    resolution: float = 0.001
    direction: Array = field(default_factory=lambda: np.zeros((0, 3)))
    rotation: Array = field(default_factory=lambda: np.zeros((0, 0)))
    rotation_ids: tuple[str, ...] = ()
    spindle: str = "Z"

    @classmethod
    def from_model(cls, model: ProcessModel, coord: Array | None = None) -> Layout:
        """Arrays of ``model``; ``coord`` (n_dimensions, 3) fills coordinates the model lacks."""
        rel = relation_matrices(model)
        pos = np.full((len(model.features), 3), np.nan)
        for i, feat in enumerate(model.features):
            if feat.position is not None:
                pos[i] = feat.position
        dim_coord = np.full((len(model.dimensions), 3), np.nan)
        for q in range(len(model.dimensions)):
            w = rel.R_FD[:, q]
            used = w != 0
            if used.any() and np.isfinite(pos[used]).all():
                dim_coord[q] = w[used] @ pos[used]
        if coord is not None:
            dim_coord = np.where(np.isnan(dim_coord), coord, dim_coord)
        n_w = len(model.wks)
        direction, rotation, rotation_ids = rotation_rows(model, rel.R_FD)
        return cls(
            composite=rel.composite,
            register_ids=tuple(model.register_ids),
            dimension_ids=tuple(model.dimension_ids),
            tools=np.arange(n_w, n_w + len(model.tools)),
            nominal=np.array([d.nominal for d in model.dimensions], dtype=float),
            lower=np.array([d.lower for d in model.dimensions], dtype=float),
            upper=np.array([d.upper for d in model.dimensions], dtype=float),
            coord=dim_coord,
            groups=tuple(d.group for d in model.dimensions),
            unit=model.unit,
            resolution=model.resolution,
            direction=direction,
            rotation=rotation,
            rotation_ids=rotation_ids,
            spindle=model.spindle,
        )

    @property
    def n_registers(self) -> int:
        return int(self.composite.shape[0])

    @property
    def n_dimensions(self) -> int:
        return int(self.composite.shape[1])

    @property
    def tool_ids(self) -> tuple[str, ...]:
        return tuple(self.register_ids[i] for i in self.tools)


def rotation_rows(model: ProcessModel, r_fd: Array) -> tuple[Array, Array, tuple[str, ...]]:
    """Measuring directions and the rotation fields of the WKS of a multi-axis model.

    A WKS turned by θ [rad] about the spindle axis s through its origin moves feature f at
    x_f by θ c_f (s × x_f) (the small-angle rotation δx = −θ y, δy = θ x about Z), c_f the
    feature's weight on the WKS (its ``c`` weight, else its ``x`` weight); dimension q
    measured along n_q moves by θ Σ_f w_qf c_f n_q · (s × x_f).  A rotation about another
    centre is this plus a translation, which the WKS's translation registers take.

    Returns
    -------
    direction : ndarray (n_dimensions, 3)
        n_q, NaN for a dimension without one (sizes and zones included); (0, 3) for a one-axis model.
    rotation : ndarray (n_rotations, n_dimensions) [model unit / rad]
    rotation_ids : tuple of str
        WKS of each row: those with at least two dimensions moved, every feature positioned and
        no rotation register (``W1.C``) in the model.
    """
    if not model.multi_axis:
        return np.zeros((0, 3)), np.zeros((0, len(model.dimensions))), ()
    direction = np.array(
        [
            d.direction if d.direction is not None and d.kind != "size" and not d.zone else (np.nan,) * 3
            for d in model.dimensions
        ],
        dtype=float,
    ).reshape(len(model.dimensions), 3)
    pos = np.array(
        [f.position if f.position is not None else (np.nan,) * 3 for f in model.features], dtype=float
    ).reshape(len(model.features), 3)
    s = np.eye(3)[AXES.index(model.spindle.lower())]
    lever = np.cross(s, pos)  # (F, 3), NaN where no position
    turned = {r.base for r in model.wks if r.component == "C"}
    rows, ids = [], []
    for w in dict.fromkeys(r.base for r in model.wks):
        if w in turned:
            continue
        c = np.array([f.components.get(w, {}).get("c", f.components.get(w, {}).get("x", 0.0)) for f in model.features])
        used = c != 0
        if not used.any() or not np.isfinite(lever[used]).all():
            continue
        moved = (c[:, None] * np.nan_to_num(lever))[:, None, :] * r_fd[:, :, None]  # (F, Q, 3)
        row = np.einsum("qk,qk->q", moved.sum(axis=0), np.nan_to_num(direction))
        if np.count_nonzero(np.abs(row) > 1e-12) >= 2:
            rows.append(row)
            ids.append(w)
    return direction, np.array(rows).reshape(len(rows), len(model.dimensions)), tuple(ids)


@dataclass(frozen=True)
class Series:
    """Measured cycles with the covariates they carry.

    Attributes
    ----------
    deviation : ndarray of shape (n_cycles, n_dimensions) [model unit]
        Measured deviation, NaN where absent.
    time : ndarray of shape (n_cycles,) [h]
        When each cycle was machined, hours since ``origin``.
    applied : ndarray of shape (n_cycles, n_registers) [model unit]
        Sum of the logged register changes in effect when the cycle was machined.
    parts : ndarray of shape (n_cycles, n_tools)
        Cycles cut by each tool since its last change (0 right after a change).
    temperature : ndarray of shape (n_cycles, n_channels)
        Recorded channels per cycle: temperature samples [°C] at or just before each
        cycle, then the process log's channels (any unit; a categorical level as a 0/1
        indicator) joined per cycle (empty when no log).
    channels : tuple of str
        Names of the columns of ``temperature``.
    cycles : tuple of str
        Cycle (part) identifiers.
    origin : str
        ISO timestamp of time 0 ("" when the series has no timestamps).
    pending : ndarray of shape (n_registers,) [model unit]
        Logged changes after the last cycle (in effect for the next one).
    process_channels : tuple of str
        The channels that come from a process log (candidates of the ``process`` kind;
        the others are temperatures, candidates of the ``thermal`` kind).
    """

    deviation: Array
    time: Array
    applied: Array
    parts: Array
    temperature: Array
    channels: tuple[str, ...] = ()
    cycles: tuple[str, ...] = ()
    origin: str = ""
    pending: Array = field(default_factory=lambda: np.zeros(0))
    process_channels: tuple[str, ...] = ()

    @property
    def n_cycles(self) -> int:
        return int(self.deviation.shape[0])

    def take(self, rows: npt.ArrayLike) -> Series:
        """The sub-series of the given cycle indices."""
        idx = np.asarray(rows)
        cycles = tuple(np.asarray(self.cycles, dtype=object)[idx]) if self.cycles else ()
        return Series(
            self.deviation[idx],
            self.time[idx],
            self.applied[idx],
            self.parts[idx],
            self.temperature[idx],
            self.channels,
            cycles,
            self.origin,
            self.pending,
            self.process_channels,
        )


@dataclass(frozen=True)
class EffectSpec:
    """One effect term: its kind and what it acts on.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    register : str, optional
        Tool (wear) or register (relation; level and process: None for every tool alike).
    dimension : str, optional
        Dimension (relation).
    axis : str, optional
        ``x``, ``y`` or ``z`` (position: the coordinate the slope is on).
    along : str, optional
        Position: the measuring direction the slope acts on (``x``: only the dimensions'
        X components, δx = β x); None for every dimension alike.
    group : str, optional
        Station or setup (group).
    channel : str, optional
        Temperature channel (thermal) or process channel (process).
    shape : str
        ``linear`` or ``saturating`` (drift).
    tau : float
        Time constant of a saturating drift [h].
    reference : float
        Temperature the thermal term is zero at [°C]; value of the process channel the
        process term is zero at [the channel's unit].
    at : float
        Time of a level step [h since the series' origin]: cycles at or after it are shifted.
    cycle : str, optional
        First cycle after a level step (for people).
    """

    kind: str
    register: str | None = None
    dimension: str | None = None
    axis: str | None = None
    group: str | None = None
    channel: str | None = None
    shape: str = "linear"
    tau: float = 0.0
    reference: float = 0.0
    at: float = 0.0
    cycle: str | None = None
    along: str | None = None

    @property
    def target(self) -> str:
        """What the effect concerns, in the words of the diagnose contract."""
        if self.kind == "drift":
            return "all tools ~ time" + (f" (saturating, tau {self.tau:g} h)" if self.shape == "saturating" else "")
        if self.kind == "thermal":
            return f"all tools ~ {self.channel}"
        if self.kind == "wear":
            return f"{self.register} ~ parts since change"
        if self.kind == "scale":
            return "all dimensions ~ nominal"
        if self.kind == "position":
            return str(self.axis) if self.along is None else f"{self.along}-errors ~ {self.axis}"
        if self.kind == "rotation":
            return f"{self.register} ~ rotation"
        if self.kind == "relation":
            return f"{self.dimension} ~ {self.register}"
        if self.kind == "level":
            return f"{self.register or 'all tools'} step at {self.cycle or f'{self.at:g} h'}"
        if self.kind == "process":
            return f"{self.register or 'all tools'} ~ {self.channel}"
        return f"group {self.group}"

    def unit(self, length: str) -> str:
        """Unit of the effect's estimate (``length`` is the model unit)."""
        return {
            "drift": f"{length}/h" if self.shape == "linear" else length,
            "thermal": f"{length}/°C",
            "wear": f"{length}/cycle",
            "scale": f"{length}/{length}",
            "position": f"{length}/{length}",
            "rotation": "rad",
            "relation": "1",
            "group": length,
            "level": length,
            "process": f"{length}/unit of {self.channel}",
        }[self.kind]


def common_tool_row(layout: Layout) -> Array:
    """Dimension change per unit growth of every tool at once, shape (n_dimensions,).

    Machine-level thermal growth along the axis lengthens every tool alike; without
    tools in the model every WKS is moved instead.
    """
    rows = layout.tools if layout.tools.size else np.arange(layout.n_registers)
    out: Array = layout.composite[rows].sum(axis=0)
    return out


def effect_field(spec: EffectSpec, layout: Layout, series: Series) -> Array:
    """Covariate field z of one effect: its contribution per unit estimate.

    Parameters
    ----------
    spec : EffectSpec
    layout : Layout
    series : Series

    Returns
    -------
    ndarray of shape (n_cycles, n_dimensions)
        The effect adds β · z to the deviations.  For a relation the field is the
        register's applied change u_k,i on the one dimension (the constant part
        δ · s_i is a separate free term, see :mod:`setupfix.diagnose.candidates`).

    Raises
    ------
    KeyError
        If the register, dimension, group, channel or axis is unknown.
    """
    factors = field_factors(spec, layout, series)
    if factors is not None:
        return np.outer(*factors)
    if spec.kind == "relation":
        i = layout.register_ids.index(str(spec.register))
        q = layout.dimension_ids.index(str(spec.dimension))
        z = np.zeros((series.n_cycles, layout.n_dimensions))
        z[:, q] = series.applied[:, i]
        return z
    raise KeyError(spec.kind)


def field_factors(spec: EffectSpec, layout: Layout, series: Series) -> tuple[Array, Array] | None:
    """The field of every kind but a relation is an outer product z = a bᵀ: per cycle a (n_cycles,), per
    dimension b (n_dimensions,).  None for a relation.  Raises KeyError as :func:`effect_field`."""
    n = series.n_cycles
    ones = np.ones(n)
    if spec.kind == "drift":
        t = series.time if spec.shape == "linear" else 1.0 - np.exp(-series.time / spec.tau)
        return t, common_tool_row(layout)
    if spec.kind == "thermal":
        ch = series.channels.index(str(spec.channel))
        return series.temperature[:, ch] - spec.reference, common_tool_row(layout)
    if spec.kind == "wear":
        j = layout.register_ids.index(str(spec.register))
        k = int(np.flatnonzero(layout.tools == j)[0])
        return series.parts[:, k], layout.composite[j]
    if spec.kind == "scale":
        return ones, layout.nominal
    if spec.kind == "position":
        a = AXES.index(str(spec.axis))
        coord = np.nan_to_num(layout.coord[:, a])
        if spec.along is None:
            return ones, coord
        if layout.direction.shape[0] != layout.n_dimensions:
            raise KeyError(f"position along {spec.along}: the model has no measuring directions")
        return ones, coord * np.nan_to_num(layout.direction[:, AXES.index(spec.along)])
    if spec.kind == "rotation":
        return ones, layout.rotation[layout.rotation_ids.index(str(spec.register))]
    if spec.kind == "group":
        mask = np.array([g == spec.group for g in layout.groups], dtype=float)
        if not mask.any():
            raise KeyError(spec.group)
        return ones, mask
    if spec.kind == "level":
        return (series.time >= spec.at).astype(float), register_row(layout, spec.register)
    if spec.kind == "process":
        return channel_values(series, str(spec.channel)) - spec.reference, register_row(layout, spec.register)
    if spec.kind == "relation":
        return None
    raise KeyError(spec.kind)


#: Separator of a product channel's factors (``a=x & b=y``: the interaction of two channels).
PRODUCT = " & "


def channel_values(series: Series, name: str) -> Array:
    """Values of a recorded channel per cycle, shape (n_cycles,).

    A name that is no channel of the series but joins channels with :data:`PRODUCT`
    (``doe_tool_length=Long & endmill_rpm``) is their product: the interaction of
    declared design factors (:mod:`setupfix.diagnose.factors`), whichever channels the
    log reader kept.

    Raises
    ------
    KeyError
        If a channel is unknown.
    """
    if name in series.channels:
        out: Array = series.temperature[:, series.channels.index(name)]
        return out
    parts = name.split(PRODUCT)
    if len(parts) < 2:
        raise KeyError(name)
    prod: Array = np.prod([channel_values(series, p) for p in parts], axis=0)
    return prod


def register_row(layout: Layout, register: str | None) -> Array:
    """Dimension change per unit change of one register (C[i]), or of every tool alike (``None``)."""
    if register is None:
        return common_tool_row(layout)
    out: Array = layout.composite[layout.register_ids.index(register)]
    return out
