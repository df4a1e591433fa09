"""How a command runs: progress lines, the failure every stage reports the same way, and
SIGINT/SIGTERM as exceptions. Pure Python."""
