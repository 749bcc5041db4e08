"""Test-suite support that must be importable under mpirun (not user API)."""
