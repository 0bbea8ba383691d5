"""Exceptions the library raises; only the CLI turns them into messages and exit codes."""


class InputError(Exception):
    """Bad input (scenario, data file or an unusable sequence): exit code 2.

    Parameters
    ----------
    message : str
        What is wrong and what was expected.
    source : str, optional
        File the problem is in.
    key : str, optional
        Key path in the scenario (``imu.gyro.bias_dph``) or column / dataset name.
    line : int, optional
        1-based line in ``source``.
    """

    def __init__(self, message, source=None, key=None, line=None):
        super().__init__(message)
        self.message = message
        self.source = source
        self.key = key
        self.line = line

    def __str__(self):
        where = []
        if self.source:
            where.append(str(self.source) + (f":{self.line}" if self.line else ""))
        if self.key:
            where.append(str(self.key))
        prefix = ": ".join(where)
        return f"{prefix}: {self.message}" if prefix else self.message


class OutputError(InputError):
    """The output folder cannot take the results (full disk, read-only, no permission):
    exit code 2 like bad input, since the folder is part of what the user gave."""
