"""The ``phri`` command and the in-process session it runs."""
