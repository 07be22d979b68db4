"""Layer 2's skeleton helpers: the generic idioms family skeletons share (poses, grasp choice, candidates,
what-if state, free spots, articulations, pick and place, task-seeded random streams)."""
