"""Published worked examples the SPC tests check against (numbers only)."""

#: Montgomery & Runger, Applied Statistics and Probability for Engineers, Table 16-3 (chemical process
#: concentration, 20 individual measurements); published x̄ = 99.1, MR̄ = 2.59, UCL 105.99, LCL 92.21.
CONCENTRATION = [102.0, 94.8, 98.3, 98.4, 102.0, 98.5, 99.0, 97.7, 100.0, 98.1,
                 101.3, 98.7, 101.1, 98.4, 97.0, 96.7, 100.3, 101.4, 97.2, 101.0]
