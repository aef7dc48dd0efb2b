"""What the use cases write: result files, controller programs, the Q-DAS transfer file, model scaffolds and figures."""
