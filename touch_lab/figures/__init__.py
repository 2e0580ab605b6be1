"""PNG figures of the evaluation reports in docs/ (matplotlib, Agg; lab only, never imported by the runtime).

:mod:`.png` draws and saves deterministically, :mod:`.plots` holds the figure kinds shared by the
reports (confusion matrix, speed against error, class posteriors over time, traces before and after
the sensor), and :mod:`.bear`, :mod:`.patch` and :mod:`.skin` make each report's figures from the
results its report command measured. The report commands import these modules inside the function
that writes the report, so ``social-touch`` itself never loads matplotlib.
"""
