"""Project error classes: the CLI maps InputError to exit 2 and ProcessingError to exit 1."""


class InputError(ValueError):
    """Bad input: a file, dataset, attribute or YAML key that is missing or wrong.

    The message names the file and the key or dataset, and says what was expected.
    """


class ProcessingError(RuntimeError):
    """A stage could not produce a valid result from valid-looking input."""


# ``extra=`` of a warning that says the output image is wrong (ghosts, aliasing, folds, ambiguities):
# shown under ``sarproc -q``, silenced only by ``-qq``.
IMAGE_DEFECT = {"image_defect": True}
