"""The thin CLI: one module per command under ``navbench.cli.commands``."""
