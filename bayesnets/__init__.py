"""Discrete Bayesian networks held as folders of CSV tables (Chuang 2011, Sec. 3.3)."""
