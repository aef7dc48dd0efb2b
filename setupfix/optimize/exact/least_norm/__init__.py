"""The least norm Σ c_i k_i² (eq. 9) among grid points: by listing, by chords on a MILP, at shop scale."""
