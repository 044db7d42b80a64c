"""The hardware-in-loop rig: simulated devices from :mod:`sim` on real interfaces (shared-memory
frame rings, pseudo-terminals) wired to an ordinary live
:class:`acquisition.runtime.session.Session`,
plus the choice of the fastest sustainable flight speed. Composition only: it is the one place
where :mod:`sim` and :mod:`acquisition` meet, so neither has to import the other."""
