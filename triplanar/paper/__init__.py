"""Reproduction of the paper's results section (Galic, Glaser & Goodman 2008, sections 4-5, Figs. 6,
11-16) against a laboratory dataset: ``reproduce(data) -> Reproduction``, ``write_outputs(rep, dir)``,
or both at once with ``run_paper(dir, data)``.

Modules: :mod:`.cases` (what is simulated), :mod:`.metrics` (distances, dilation, rotation),
:mod:`.tables`, :mod:`.claims` (the numbered claims, ``docs/paper-reproduction.md``), :mod:`.figures`,
:mod:`.reproduce` (orchestration).
"""

from .claims import CLAIMS, Claim, evaluate
from .reproduce import (Reproduction, default_data_path, figure_specs, render_figures, reproduce, run_paper,
                        write_outputs)

__all__ = ["CLAIMS", "Claim", "evaluate", "Reproduction", "default_data_path", "figure_specs", "render_figures",
           "reproduce", "run_paper", "write_outputs"]
