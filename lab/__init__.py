"""The lab: research scripts, probes, outside-set generators, trial recipes and their notes. Not installed
and not the product; run a script from the repository root as ``python -m lab.<name>`` (lab/README.md)."""
