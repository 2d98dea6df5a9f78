"""The hidden-effect scenarios the workbench is checked against (tests and benchmark share them).

Each built-in effect, with the value a dataset is made with and the parameters a fit must recover.
"""

from __future__ import annotations

#: effect -> (the ``--effect`` spec the data are made with, the parameters the fit must recover within 15 %)
HIDDEN_EFFECTS: dict[str, tuple[str, dict[str, float]]] = {
    "end_friction": ("end_friction:phi_deg=8", {"phi_deg": 8.0}),
    "rate_friction": ("rate_friction:a=0.3", {"a": 0.3}),
    "tip_offset": ("tip_offset:offset_m=-0.005", {"offset_m": -0.005}),
    "actuator_rise": ("actuator_rise:tau_s=0.05", {"tau_s": 0.05}),
    "contact_friction": ("contact_friction:phi1_deg=15,phi2_deg=17,phi3_deg=10",
                         {"phi1_deg": 15.0, "phi2_deg": 17.0, "phi3_deg": 10.0}),
    "plane_tilt": ("plane_tilt:dip2_deg=2.5", {"dip2_deg": 2.5}),
}
