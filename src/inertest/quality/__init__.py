"""Metrology of a result: the lab's equipment, the uncertainty budget, verdicts, plan checks.

:mod:`~inertest.quality.lab` reads the lab's equipment records (identities, calibration due
dates, Type-B uncertainties) and writes the test's identity block; :mod:`~inertest.quality.budget`
combines the Type-A uncertainty of a fit with the Type-B sources of the equipment and the site
(JCGM 100:2008); :mod:`~inertest.quality.conformance` judges the result against a specification
under its decision rule (ILAC-G8); :mod:`~inertest.quality.plan_check` predicts, before a test,
which limits the plan can verify.
"""
