"""Helpers the tests and benches share, as plain modules (fixtures stay in conftest.py):
paths of the tree (`paths`), the demo machine's channel without files (`channel`), closed-loop
runs of the GEO core on a virtual clock (`closed_loop`), `liftd run` as a subprocess
(`daemon`), the ADS server with a test snapshot (`ads_harness`, `ads_fake`) and the attack
cases (`attacks`)."""
