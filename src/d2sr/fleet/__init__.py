"""Many recordings repaired on Ray (``d2sr fleet``): each recording is one task with its own sensor loop,
written exactly as ``d2sr recover`` writes it, one folder of outputs for the whole fleet, resumable.

``recover_fleet(recordings, out, settings, written, cluster=Cluster(...))`` is the one call; ``Cluster``
says where it runs (a local cluster of ``workers``, or one at ``address``). Ray is the ``fleet`` extra.
"""

from d2sr.fleet.cluster import Cluster
from d2sr.fleet.ledger import LEDGER, Outcome
from d2sr.fleet.run import FleetProgress, FleetSummary, recover_fleet

__all__ = ["LEDGER", "Cluster", "FleetProgress", "FleetSummary", "Outcome", "recover_fleet"]
