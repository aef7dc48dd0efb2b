"""The correction engine around the optimiser.

Relation matrices, the objective, posing a cycle's problem, safety rules, the recommendation,
EWMA smoothing, explanations, position zones and offset rows: arrays in, arrays out, no I/O.
"""
