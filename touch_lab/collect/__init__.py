"""Labelled recording sessions: the protocol, the session bag (sensor topics + ``/touch/label``), simulated people.

``social-touch collect`` (:mod:`.cli`) records them; ``train`` and ``eval`` read them back with
:func:`.session_bag.read_session`.
"""
