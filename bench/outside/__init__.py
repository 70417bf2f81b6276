"""The outside sets: interference written apart from the project's generator, on real frames of
../shared/data, and the benchmark that runs the public CLI on them (``python -m bench.outside``; its
docstring says what each set is and what it measures)."""
