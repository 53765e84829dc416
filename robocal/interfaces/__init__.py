"""Layer 8: the command line, reports and plots."""
