"""Why a fleet prior checks the catalogue band's optimum at ``FLEET_VETO_Z`` sd, in words.

Kept apart from :mod:`supervisor.fleet.provenance` (which loads NumPy) so that the CLI's
readers and the report can say it without loading NumPy (``rcb --help`` loads none:
tests/api/test_cli_startup.py).
"""

from __future__ import annotations

#: The reasons, by the keys stored in a provenance's ``band_checked_because``
#: (:attr:`supervisor.fleet.provenance.Provenance.band_checked_why`): the machines' spread of
#: ln K passes the band (:func:`supervisor.fleet.prior._beyond_band`), or a plan of the tool
#: halted (:func:`supervisor.fleet.prior._prior`).
BAND_CHECKED_WHY = {
    "spread": "machines differ by more than the catalogue band",
    "halted": "a plan of its tool halted",
}
