"""Evaluation: rally statistics with confidence intervals, tables and plots."""
