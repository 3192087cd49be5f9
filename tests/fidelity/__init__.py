"""Fidelity tests: one test per statement of the vendor text (docs/reference/lift-function-*.txt,
the German text authoritative), each named after the seed section it checks (`test_s2_1_3_…`
checks §2.1.3), each on a program of its own."""
