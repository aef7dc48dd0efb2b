"""Triage: when no correction brings every dimension into tolerance, give up only what must be."""
