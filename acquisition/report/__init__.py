"""The report of a session: the paper's figures and the stop table, from a recording or a live
table."""
