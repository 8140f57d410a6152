"""Figures and the self-contained HTML report (matplotlib, imported only where a figure is drawn).

Reports are written without a display: the Agg backend is chosen unless the user set one.
"""

import os

os.environ.setdefault("MPLBACKEND", "Agg")
