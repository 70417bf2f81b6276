"""The jobs that run the loop (``d2sr.runtime``): a recording repaired or judged and its report
(``recordings``, ``scenes``, ``output``, ``report``), ``d2sr run`` on a simulated room, a recording or a live
sensor (``runner``, ``session``, ``sources``, ``live``, ``shots``, ``trigger_check``), and what they show
(``stats``, ``viewer``). Each takes the run's settings objects."""
