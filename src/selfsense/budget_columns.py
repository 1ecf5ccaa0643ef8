"""The column suffixes the error budgets (:mod:`selfsense.error_budget`, :mod:`selfsense.tracking_budget`)
write and the scorecard's causes (:class:`selfsense.scorecard.Cause`) read, named here once so that
neither imports the other."""

#: a source's value at the instant of the error's max
AT_MAX = " at total max [µm]"
#: a source's σ over P1's tests of its value at each test's max (error_budget.spread_over_spans)
AT_MAX_SPREAD = " at max σ over tests [µm]"
