"""The result of a contact simulation: femb's Result plus per-contact outputs and impact events."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from femb.errors import ModelError
from femb.results.result import Result

#: contact states in ``ContactResult.contact["state"]``
OPEN, STICK, SLIP = 0, 1, 2
STATE_NAMES = {OPEN: "open", STICK: "stick", SLIP: "slip"}

#: per-contact outputs: key of ``contact`` → (suffix, unit, meaning)
NORMAL_OUTPUTS = {
    "gN": ("gN", "m", "gap g_N"),
    "gN_d": ("gN_d", "m/s", "normal relative velocity ġ_N"),
    "lam_N": ("lambda_N", "N", "normal contact force λ_N"),
    "Lam_N": ("Lambda_N", "N·s", "normal percussion Λ_N (impulsive part), summed over the step's substeps"),
    "P_N": ("P_N", "N·s", "normal impulse of the step P_N = Λ_N + h-weighted λ_N, summed over its substeps"),
    "state": ("state", "1", "0 open, 1 stick, 2 slip"),
}
FRICTION_OUTPUTS = {
    "gam_F": ("gamma_F", "m/s", "slip velocity γ_F along the tangent"),
    "lam_F": ("lambda_F", "N", "friction force λ_F"),
    "Lam_F": ("Lambda_F", "N·s", "friction percussion Λ_F, summed over the step's substeps"),
    "P_F": ("P_F", "N·s", "friction impulse of the step P_F, summed over its substeps"),
}


@dataclass(repr=False)          # the summary of Result.__repr__ / _repr_html_, not the dataclass's field dump
class ContactResult(Result):
    """:class:`femb.results.result.Result` with contact outputs (docs/contact.md §6).

    Attributes
    ----------
    contact : dict of str to ndarray
        Per stored step: ``gN``, ``gN_d``, ``lam_N``, ``Lam_N``, ``P_N``, ``state`` (nt, nN);
        ``gam_F``, ``lam_F``, ``Lam_F``, ``P_F`` (nt, nF); ``work_N``, ``work_F`` (nt,): the
        cumulative work of the normal and tangential contact impulses (J, ≤ 0: energy taken out).
    contact_names : list of str
        Contact element of each of the nN contacts.
    friction_rows : list of ndarray
        Tangent rows of each contact.
    events : list of dict
        Impacts: ``t``, ``step``, ``contact``, ``v_before``, ``v_after`` (ġ_N, m/s), ``Lambda_N``.
    stats : dict
        ``steps``; ``substeps`` (the steps split at impacts count their parts); ``fixed_point_steps``:
        (sub)steps that the semismooth Newton method did not solve and the prox fixed point did;
        ``slip_on_P_steps``: (sub)steps solved only with the slip law on the whole percussions
        (docs/contact.md §1.1 item 5: a sticking contact that starts to slip). Adaptive runs
        (docs/contact.md §1.2) add ``rejected_steps``, ``unchecked_steps`` (steps with an impact or a
        change of contact state, accepted without an error test) and ``failed_solves`` (tries without
        a solution, taken again with h/4), and set ``h_steps`` and ``n_rejected``. Runs with the broad
        phase (docs/contact.md §7) add ``broad_phase``: ``solves`` (steps and substeps solved, repeats
        included), ``repeated`` (solved again with pairs that came close), ``rebuilt`` (new subsets of
        the contacts) and ``mean_contacts`` (contacts per solve).
    """

    contact: dict = field(default_factory=dict)
    contact_names: list = field(default_factory=list)
    friction_rows: list = field(default_factory=list)
    events: list = field(default_factory=list)

    def _summary(self):
        """Result's summary with a row for the contacts: how many, impacts, the smallest gap."""
        from femb.base.summary import short_list

        title, rows = super()._summary()
        gN = self.contact.get("gN")
        gap = f", min g_N = {float(np.min(gN)):.3g} m" if gN is not None and gN.size else ""
        rows.append(("contacts", f"{len(self.contact_names)} ({short_list(self.contact_names, 4)}), "
                                 f"{len(self.events)} impacts{gap} (events, contact_state(name))"))
        return title, rows

    def _steps_label(self, how):
        """The steps, and the substeps where impacts split some (:attr:`steps` counts the substeps)."""
        n, sub = self.stats.get("steps"), self.stats.get("substeps")
        if n is None or sub is None or sub == n:
            return super()._steps_label(how)
        return f"{n} ({how}; {sub} substeps)"

    def _contact_series(self, name):
        for i, cname in enumerate(self.contact_names):
            if not name.startswith(cname + "."):
                continue
            suffix = name[len(cname) + 1:]
            for key, (suf, unit, _) in NORMAL_OUTPUTS.items():
                if suffix == suf:
                    return np.array(self.contact[key][:, i], dtype=float), unit
            rows = self.friction_rows[i]
            for key, (suf, unit, _) in FRICTION_OUTPUTS.items():
                for k, r in enumerate(rows):
                    if suffix == (suf if len(rows) == 1 else f"{suf}{k + 1}"):
                        return np.array(self.contact[key][:, r]), unit
            if suffix == "slip" and len(rows):
                return np.linalg.norm(self.contact["gam_F"][:, rows], axis=1), "m/s"
        return None

    def series(self, name):
        """As :meth:`femb.results.result.Result.series`, plus per contact ``<contact>.gN``, ``.gN_d``,
        ``.lambda_N``, ``.Lambda_N``, ``.P_N``, ``.state``, ``.slip`` (|γ_F|) and ``.gamma_F``,
        ``.lambda_F``, ``.Lambda_F``, ``.P_F`` (spatial: ``gamma_F1``, ``gamma_F2``, …), and
        ``energy.contact_normal`` / ``energy.contact_friction``."""
        out = self._contact_series(name)
        if out is not None:
            return out
        if name in ("energy.contact_normal", "energy.contact_friction"):
            return self.energy()[name.split(".")[1]], "J"
        return super().series(name)

    def outputs(self):
        names = list(super().outputs())
        for i, cname in enumerate(self.contact_names):
            names += [f"{cname}.{suf}" for suf, _, _ in NORMAL_OUTPUTS.values()]
            rows = self.friction_rows[i]
            for suf, _, _ in FRICTION_OUTPUTS.values():
                names += [f"{cname}.{suf}"] if len(rows) == 1 else [f"{cname}.{suf}{k + 1}" for k in range(len(rows))]
            if len(rows):
                names.append(f"{cname}.slip")
        return names + ["energy.contact_normal", "energy.contact_friction"]

    def energy(self):
        """femb's energies plus ``contact_normal`` and ``contact_friction``: the energy taken out by
        the normal (impacts, persistent contact) and tangential contact impulses, cumulative (J ≥ 0);
        ``balance`` includes them."""
        e = super().energy()
        e["contact_normal"] = -np.asarray(self.contact["work_N"], dtype=float)
        e["contact_friction"] = -np.asarray(self.contact["work_F"], dtype=float)
        e["balance"] = e["balance"] + e["contact_normal"] + e["contact_friction"]
        return e

    def contact_at(self, k):
        """(state (nN,), λ_N (nN,), λ_F (nF,)) at stored step ``k``: what the contact elements draw."""
        return self.contact["state"][k], self.contact["lam_N"][k], self.contact["lam_F"][k]

    def contact_state(self, name):
        """The state of contact ``name`` at every stored step, as strings (open, stick, slip)."""
        if name not in self.contact_names:
            raise ModelError(f"no contact named '{name}' (known: {self.contact_names})")
        i = self.contact_names.index(name)
        return [STATE_NAMES[int(s)] for s in self.contact["state"][:, i]]
