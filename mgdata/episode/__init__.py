"""The per-step episode runtime shared by generation, teleop and evaluation: the runner (controller →
recorder → gate), the keep/discard gate and failure stages, the success check, timings and deferred
rendering."""
