"""Acceptance tests of a robot's accuracy in the language of standards (ISO 9283)."""
