"""rtlab application: CLI, frame loop, viewer, headless runner, benchmark and report."""
