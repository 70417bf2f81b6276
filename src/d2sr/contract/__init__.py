"""What the learned stages and everything around them agree on, torch-free: the model catalogue
(``catalog``: names, files, sizes, thresholds), the repair (``repair``: the guard, the passes, the scene's
part) and how a repair is scored (``metrics``)."""
