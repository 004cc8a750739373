"""Figures: one bounce, and the figures of a run (the paper's Figs. 3-9, diagnostics, residuals).

Every figure is a ``matplotlib.figure.Figure`` drawn without pyplot; matplotlib is imported
when a figure is drawn, not when this package is imported. Every axis carries its unit, every
figure a legend, and axis limits come from robust ranges of the data: values beyond them are
drawn at the edge and counted, never dropped silently.
"""

from ._bounce import plot_bounce as plot_bounce
from ._comparison import plot_comparison as plot_comparison
from ._data import measured_density as measured_density
from ._data import plot_data as plot_data
from ._data import plot_predictive as plot_predictive
from ._derived import plot_derived as plot_derived
from ._figure import FIGURE_FORMATS as FIGURE_FORMATS
from ._figure import STYLE as STYLE
from ._figure import save_figure as save_figure
from ._figure import save_figures as save_figures
from ._limits import robust_limits as robust_limits
from ._posterior import plot_diagnostics as plot_diagnostics
from ._posterior import plot_joint_posterior as plot_joint_posterior
from ._posterior import plot_marginals as plot_marginals
from ._population import plot_population as plot_population
from ._propagation import plot_contact_time as plot_contact_time
from ._propagation import plot_forces as plot_forces
from ._propagation import plot_trajectories as plot_trajectories
from ._residuals import Residuals as Residuals
from ._residuals import plot_residuals as plot_residuals
from ._residuals import posterior_residuals as posterior_residuals

__all__ = ["FIGURE_FORMATS", "STYLE", "Residuals", "measured_density", "plot_bounce", "plot_comparison", "plot_contact_time",
           "plot_data", "plot_derived", "plot_diagnostics", "plot_forces", "plot_joint_posterior",
           "plot_marginals", "plot_population", "plot_predictive", "plot_residuals",
           "plot_trajectories", "posterior_residuals", "robust_limits", "save_figure",
           "save_figures"]
