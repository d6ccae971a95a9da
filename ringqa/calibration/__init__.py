"""Calibration of the cable model on the clinic's own measured source paths (issue 26).

:func:`~ringqa.calibration.run.calibrate` fits scene keys (default ``contact.mu_k``,
``contact.mu_s``, ``instrument.ei_scale``) so that the simulated dwells match one or more
measured paths by weighted least squares (:mod:`.fit`), reports the fitted values with standard
errors, correlations and an ``identifiable`` flag per key, residuals before and after, and with
two or more applicators the prediction error of each left out of the fit; :mod:`.output` writes
``calibration.json``, ``calibrated_cable.toml``, ``residuals.csv``, ``calibration.png`` and
``calibration.pdf``. See docs/calibration.md.

Modules: :mod:`.measured` (the measured paths, read, registered and flagged), :mod:`.model`
(parameters -> simulated points), :mod:`.fit` (the least squares and its statistics),
:mod:`.run` (the whole calibration), :mod:`.output` (the files).
"""
