"""The hardware-in-loop rig: simulated devices from :mod:`snrmon.sim` on real interfaces
(shared-memory frame rings, pseudo-terminals) wired to an ordinary live
:class:`snrmon.acquisition.runtime.session.Session`,
plus the choice of the fastest sustainable flight speed. Composition only: it is the one place
where :mod:`snrmon.sim` and :mod:`snrmon.acquisition` meet, so neither has to import the other."""
