"""Leximin centring on the register grid.

The levels (:mod:`.levels`), one level (:mod:`.level`), which margins a level pins (:mod:`.pins`),
counts past a discrete conflict (:mod:`.counts`), the local search (:mod:`.search`) and the
outcome with its least norm (:mod:`.result`).
"""
