"""Layer 7: the command line, reports and plots, model files."""
