"""Lab commands of ``social-touch``: eval, train, bench, codebook, report."""
