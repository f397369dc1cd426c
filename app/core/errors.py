"""The errors srg tells its users about: one base, a few meanings.

Every layer raises these for what the user can act on (a bad name, an unknown graph, a
graph already busy). The shells map them in one place each: the CLI prints any
``SrgError`` as one ``srg: error:`` line and exits 2 (``app.cli.output``); the API answers
it with the ``http_status`` of its kind and a ``{error, details}`` body
(``app.api.errors``). Any other exception is a bug and shows as one: a traceback on the
CLI, a 500 in the API. The base sits in the pure core so that the core's own refusals
(an invalid name, a model that cannot be parsed) join the same family without the core
importing anything outside itself.

``InvalidInput`` and ``NotFound`` keep Python's own meanings (``ValueError``,
``LookupError``) as second bases, so that code catching those still catches ours.
"""


class SrgError(Exception):
    """An error the user (operator, player, script) can act on.

    ``details`` is what a script needs to act on it (which step of a trace, say); the
    API answers it as the body's ``details``.
    """

    http_status = 400

    def __init__(self, *args: object, details: object = None) -> None:
        super().__init__(*args)
        self.details = details


class InvalidInput(SrgError, ValueError):
    """A value the user gave is refused: a name, an option, an upload."""

    http_status = 422


class NotFound(SrgError, LookupError):
    """Something the user named does not exist (a graph, a publication, an experiment)."""

    http_status = 404


class Conflict(SrgError):
    """The request clashes with the current state: a name taken, a graph busy growing."""

    http_status = 409


class Inconsistent(SrgError):
    """What srg holds breaks its own rules: a graph whose vertices, clips and edges do
    not fit together. A bug or damaged data, never the user's doing, but named all the
    same: one line on the CLI and a JSON body in the API, which say which rule broke,
    where a bare ``AssertionError`` would show a traceback or an opaque 500."""

    http_status = 500


class Unavailable(SrgError):
    """A part srg needs is not there or not ready: a database never migrated, no broker."""

    http_status = 503
