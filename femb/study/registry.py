"""Registry of femb's benchmark scenes and the scene module protocol.

A *scene* is a Python module (or a file, for ``femb run path/to/scene.py``)
that describes one mechanism built from femb elements. The command line
(:mod:`femb.console.cli`), the convergence study (:mod:`femb.benchmarks.accuracy.convergence`)
and the figures (:mod:`femb.benchmarks.accuracy.figures`) only talk to scenes through
this protocol:

``build(**params) -> Mechanism``  (required)
    Builds the mechanism from femb elements; every keyword argument has a
    default, so ``build()`` is the published benchmark. ``femb run --set
    NAME=VALUE`` passes keyword arguments. Returning a compiled
    :class:`~femb.system.model.Model` is accepted as well.

``DEFAULTS = {"t_end": ..., "h": ..., "rho_inf": ...}``  (required for built-in scenes)
    The run settings of the published plots. A scene file without it needs
    ``--t-end`` and ``--h`` on the command line (ρ∞ defaults to 0.7).

``PARAMETERS = {name: (meaning, unit)}``  (required for built-in scenes)
    What each keyword of ``build`` means and its unit (``"-"`` when it has
    none), printed by ``femb list``. Every parameter of ``build`` must be
    described.

``OUTPUTS = {name: (meaning, unit)}``  (required for built-in scenes)
    The same for the names returned by ``outputs``.

``outputs(result) -> dict[str, ndarray (nt,)]``  (required for built-in scenes)
    Named physical outputs over the stored time steps of a
    :class:`~femb.results.result.Result`. Without it the outputs are the free
    coordinates, named by ``Model.coord_labels`` (e.g. ``"crank.theta"``).

``reference(t, **params) -> dict``  (optional)
    An independent reference (never femb itself) at the times ``t``: output
    names mapped to arrays (nt,), plus a ``"description"`` string saying how
    it was obtained. Without it, the convergence study uses a femb run with a
    much smaller step as its reference (and says so).

``COMPILE = {...}``  (optional)
    Keyword arguments of :meth:`~femb.Mechanism.compile` (e.g. ``{"redundant":
    "eliminate"}`` for a structurally redundant closed loop).

``CONVERGENCE = {"t_end", "h": [...], "q": [...], "lambda": [...], "v": [...]}``  (optional)
    The h-convergence study: final time, step sizes, and the output names of
    the coordinates and of the multipliers whose relative errors at ``t_end``
    are measured; ``"v"`` optionally names the velocity outputs (default: the
    position names with ``_d`` appended, where the scene has them). Without it the study uses ``DEFAULTS["t_end"]``,
    ``DEFAULTS["h"]`` × (1, 1/2, 1/4, 1/8), and the outputs split by name
    (names starting with ``lambda`` or ``R_`` are multipliers).

The scene's module docstring (first line) is its one-line description in
``femb list``.

Adding a built-in scene: write ``benchmarks/<name>.py`` following the protocol
and add ``"<name>": "femb.benchmarks.<name>"`` to :data:`SCENES`.
"""
from __future__ import annotations

import importlib
import importlib.util
import inspect
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: Built-in scenes: name -> module.
SCENES = {
    "slider_crank": "femb.benchmarks.scenes.planar.slider_crank",
    "andrews": "femb.benchmarks.scenes.planar.andrews",
    "flexible_slider_crank": "femb.benchmarks.scenes.beams.flexible_slider_crank",
    "spin_up": "femb.benchmarks.scenes.beams.spin_up",
    "pendulum": "femb.benchmarks.scenes.planar.pendulum",
    "double_pendulum": "femb.benchmarks.scenes.planar.double_pendulum",
    "two_bar_pendulum": "femb.benchmarks.scenes.planar.two_bar_pendulum",
    "spring_pendulum": "femb.benchmarks.scenes.planar.spring_pendulum",
    "force_pulse": "femb.benchmarks.scenes.planar.force_pulse",
    "bead_attractor": "femb.benchmarks.scenes.planar.bead_attractor",
    "fourbar_driven": "femb.benchmarks.scenes.planar.fourbar_driven",
    # spatial (Lie-group generalized-α on R³ × SO(3))
    "heavy_top": "femb.benchmarks.scenes.spatial.heavy_top",
    "spatial_slider_crank": "femb.benchmarks.scenes.spatial.spatial_slider_crank",
    "bricard": "femb.benchmarks.scenes.spatial.bricard",
    "spatial_double_pendulum": "femb.benchmarks.scenes.spatial.spatial_double_pendulum",
    "right_angle_cantilever": "femb.benchmarks.scenes.beams.right_angle_cantilever",
    "rigid_chain_3d": "femb.benchmarks.scenes.spatial.rigid_chain_3d",
    "spin_up_3d": "femb.benchmarks.scenes.beams.spin_up_3d",
    "flexible_fourbar_3d": "femb.benchmarks.scenes.beams.flexible_fourbar_3d",
    # rolling without slip: velocity-level (non-holonomic) constraints (docs/linearize.md)
    "whipple_bicycle": "femb.benchmarks.scenes.spatial.whipple_bicycle",
    # penalty (compliant) contact: force elements of the compiled engine (docs/contact.md)
    "penalty_ball": "femb.benchmarks.scenes.contact.penalty_ball",
    "penalty_backspin": "femb.benchmarks.scenes.contact.penalty_backspin",
    "penalty_spheres": "femb.benchmarks.scenes.contact.penalty_spheres",
}

#: Scenes that are not time integrations (static equilibria, linearized buckling): name -> module.
#: Besides the protocol above they define ``ANALYSIS`` ("static" or "buckling") and
#: ``solve(model, **params) -> Result`` (``t`` holds the load factors, or the critical loads),
#: which ``femb run`` calls instead of the time integration. They are not in :func:`names`
#: (the time-step studies and the benchmark suite run those).
STATIC_SCENES = {
    "beam_rollup": "femb.benchmarks.scenes.beams.beam_rollup",
    "beam_bend45": "femb.benchmarks.scenes.beams.beam_bend45",
    "argyris_frame": "femb.benchmarks.scenes.beams.argyris_frame",
    "deep_arch": "femb.benchmarks.scenes.beams.deep_arch",
}

#: Scenes with unilateral contact run by the nonsmooth generalized-α of :mod:`femb.contact` (fixed
#: steps; docs/contact.md): name -> module. ``femb run NAME`` integrates them with
#: :func:`femb.contact.simulate`, ``femb bench contact NAME`` runs their validation against the
#: references of docs/contact.md §5. They are not in :func:`names` (the compiled engine's
#: time-step studies and the benchmark suite run those).
CONTACT_SCENES = {
    "contact_ball": "femb.benchmarks.scenes.contact.contact_ball",
    "contact_block": "femb.benchmarks.scenes.contact.contact_block",
    "contact_rocking": "femb.benchmarks.scenes.contact.contact_rocking",
    "contact_slider_crank": "femb.benchmarks.scenes.contact.contact_slider_crank",
    "contact_painleve": "femb.benchmarks.scenes.contact.contact_painleve",
    "contact_sphere3d": "femb.benchmarks.scenes.contact.contact_sphere3d",
    "contact_tippetop": "femb.benchmarks.scenes.contact.contact_tippetop",
    "contact_beam_stop": "femb.benchmarks.scenes.contact.contact_beam_stop",
    "contact_woodpecker": "femb.benchmarks.scenes.contact.contact_woodpecker",
    "contact_spheres": "femb.benchmarks.scenes.contact.contact_spheres",
}

#: Run settings used for a scene file without DEFAULTS (only ρ∞; t_end and h must be given).
FALLBACK_RHO_INF = 0.7


class SceneError(ValueError):
    """A scene cannot be found or loaded, or does not follow the protocol."""


@dataclass
class Scene:
    """A loaded scene: its module plus uniform access to the protocol.

    Attributes
    ----------
    name : str
        Registry name, or the file's stem for a scene file.
    module : module
    source : str
        The module name or the file path.
    """

    name: str
    module: object
    source: str

    # ---------------------------------------------------------------- metadata
    @property
    def description(self):
        """First line of the module docstring."""
        doc = (self.module.__doc__ or "").strip()
        return doc.splitlines()[0].strip() if doc else ""

    @property
    def defaults(self):
        """Run settings {"t_end", "h", "rho_inf"}; missing ones are None (ρ∞: 0.7)."""
        d = dict(getattr(self.module, "DEFAULTS", {}) or {})
        return {"t_end": d.get("t_end"), "h": d.get("h"),
                "rho_inf": d.get("rho_inf", FALLBACK_RHO_INF)}

    def parameters(self):
        """Keyword parameters of ``build`` with their defaults (``inspect.Parameter.empty`` if none)."""
        sig = inspect.signature(self.module.build)
        return {p.name: p.default for p in sig.parameters.values()
                if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}

    def accepts_any_parameter(self):
        sig = inspect.signature(self.module.build)
        return any(p.kind == p.VAR_KEYWORD for p in sig.parameters.values())

    def parameter_info(self):
        """Parameters of ``build`` with default, meaning and unit.

        Returns
        -------
        dict
            ``{name: (default, meaning, unit)}`` in the order of ``build``'s
            signature; ``default`` is ``inspect.Parameter.empty`` for a required
            parameter, ``meaning`` and ``unit`` are ``""`` when the scene's
            ``PARAMETERS`` does not describe the name.
        """
        info = dict(getattr(self.module, "PARAMETERS", {}) or {})
        out = {}
        for name, default in self.parameters().items():
            meaning, unit = _pair(info.get(name), self, "PARAMETERS", name)
            out[name] = (default, meaning, unit)
        return out

    def output_info(self):
        """Described outputs ``{name: (meaning, unit)}`` (the scene's ``OUTPUTS``; empty if none)."""
        info = dict(getattr(self.module, "OUTPUTS", {}) or {})
        return {name: _pair(v, self, "OUTPUTS", name) for name, v in info.items()}

    def undocumented(self):
        """Names of ``build`` parameters that ``PARAMETERS`` does not describe, and names in
        ``PARAMETERS`` that ``build`` does not accept (each a sorted list)."""
        info = set(getattr(self.module, "PARAMETERS", {}) or {})
        known = set(self.parameters())
        return sorted(known - info), sorted(info - known)

    @property
    def has_reference(self):
        return callable(getattr(self.module, "reference", None))

    # ---------------------------------------------------------------- protocol
    def check_parameters(self, params):
        """Raise :class:`SceneError` for names ``build`` does not accept."""
        if self.accepts_any_parameter():
            return
        known = self.parameters()
        bad = sorted(set(params) - set(known))
        if bad:
            raise SceneError(f"scene '{self.name}' has no parameter {', '.join(repr(b) for b in bad)} "
                             f"(known: {', '.join(known) or 'none'})")

    def model(self, **params):
        """Build and compile the mechanism; returns a :class:`~femb.system.model.Model`."""
        from femb.system.model import Model

        self.check_parameters(params)
        obj = self.module.build(**params)
        if isinstance(obj, Model):
            return obj
        compile_ = getattr(obj, "compile", None)
        if compile_ is None:
            raise SceneError(f"scene '{self.name}': build() returned {type(obj).__name__}, "
                             "expected a femb Mechanism or Model")
        return compile_(**dict(getattr(self.module, "COMPILE", {}) or {}))

    def outputs(self, result):
        """Named outputs over the stored steps (the scene's, or the free coordinates)."""
        fn = getattr(self.module, "outputs", None)
        if fn is not None:
            return {k: np.asarray(v) for k, v in fn(result).items()}
        return {label: result.q[:, i] for i, label in enumerate(result.model.coord_labels)}

    def reference(self, t, **params):
        """The scene's independent reference at times ``t`` (see the protocol)."""
        if not self.has_reference:
            raise SceneError(f"scene '{self.name}' has no reference()")
        return self.module.reference(t, **params)

    def convergence_setup(self, output_names=()):
        """The convergence settings {"t_end", "h", "q", "lambda"} (see the protocol)."""
        conv = dict(getattr(self.module, "CONVERGENCE", {}) or {})
        d = self.defaults
        t_end = conv.get("t_end", d["t_end"])
        h = conv.get("h")
        if h is None and d["h"] is not None:
            h = [d["h"] / 2 ** k for k in range(4)]
        q, lam = conv.get("q"), conv.get("lambda")
        if q is None or lam is None:
            mult = [n for n in output_names if n.startswith(("lambda", "R_"))]
            coord = [n for n in output_names if n not in mult]
            q = coord if q is None else q
            lam = mult if lam is None else lam
        out = {"t_end": t_end, "h": list(h) if h is not None else None, "q": list(q), "lambda": list(lam)}
        if "v" in conv:
            out["v"] = list(conv["v"])
        return out


def _pair(value, scene, what, name):
    """(meaning, unit) of one PARAMETERS/OUTPUTS entry; ("", "") when absent."""
    if value is None:
        return "", ""
    if isinstance(value, str):
        return value, ""
    try:
        meaning, unit = value
    except (TypeError, ValueError):
        raise SceneError(f"scene '{scene.name}': {what}[{name!r}] must be (meaning, unit), "
                         f"got {value!r}") from None
    return str(meaning), str(unit)


def names():
    """Names of the built-in scenes (sorted)."""
    return sorted(SCENES)


def static_names():
    """Names of the built-in static and buckling scenes (sorted)."""
    return sorted(STATIC_SCENES)


def contact_names():
    """Names of the built-in nonsmooth contact scenes (sorted)."""
    return sorted(CONTACT_SCENES)


def _registered(name):
    """The module name of a registered scene of any kind, or None."""
    return SCENES.get(name) or STATIC_SCENES.get(name) or CONTACT_SCENES.get(name)


def is_path(spec):
    """True when ``spec`` designates a file rather than a registry name."""
    spec = str(spec)
    return spec.endswith(".py") or os.sep in spec or (os.altsep is not None and os.altsep in spec)


def load(spec):
    """Load a scene by registry name or from a Python file.

    Parameters
    ----------
    spec : str or Path
        A name of :data:`SCENES`, :data:`STATIC_SCENES` or :data:`CONTACT_SCENES`, or a path to a ``.py`` file defining ``build()``.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        Unknown name, missing file, a file that fails to import, or no ``build``.
    """
    spec = str(spec)
    if _registered(spec):
        source = _registered(spec)
        module = importlib.import_module(source)
        scene = Scene(spec, module, source)
    elif is_path(spec) or Path(spec).is_file():
        path = Path(spec)
        if not path.is_file():
            raise SceneError(f"scene file '{spec}' does not exist")
        mod_name = f"femb_scene_{path.stem}"
        loader_spec = importlib.util.spec_from_file_location(mod_name, path)
        if loader_spec is None or loader_spec.loader is None:
            raise SceneError(f"cannot load scene file '{spec}' (not a Python file?)")
        module = importlib.util.module_from_spec(loader_spec)
        try:
            loader_spec.loader.exec_module(module)
        except Exception as exc:  # the user's file: report, do not crash
            raise SceneError(f"scene file '{spec}' failed to import: {type(exc).__name__}: {exc}") from exc
        scene = Scene(path.stem, module, str(path))
    else:
        raise SceneError(f"unknown scene '{spec}' (built-in scenes: {', '.join(names())}; "
                         "or give a path to a .py file defining build())")
    if not callable(getattr(scene.module, "build", None)):
        raise SceneError(f"scene '{scene.name}' ({scene.source}) defines no build() function")
    return scene


def scene_module(name):
    """The module of a benchmark scene by its short name.

    ``"andrews"`` -> ``"femb.benchmarks.scenes.planar.andrews"``: a scene of :data:`SCENES` or
    :data:`STATIC_SCENES`, or any module of the scene families (``femb.benchmarks.scenes.planar``,
    ``spatial``, ``beams``, ``contact``), registered or not.
    """
    if _registered(name):
        return _registered(name)
    import importlib.util

    for family in ("planar", "spatial", "beams", "contact"):
        full = f"femb.benchmarks.scenes.{family}.{name}"
        if importlib.util.find_spec(full) is not None:
            return full
    raise SceneError(f"unknown scene module '{name}'; scenes: {', '.join(names())}")
