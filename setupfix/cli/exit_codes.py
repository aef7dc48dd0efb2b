"""Exit statuses of the ``setupfix`` command."""

OK = 0
ERROR = 1  #: bad input or a result that could not be produced; one line on stderr
USAGE = 2  #: wrong arguments
UNEXPECTED = 3  #: a bug: an exception setupfix did not raise on purpose
PARTIAL = 4  #: batch/parse: some files failed, the others were processed
INTERRUPTED = 130
REJECTED = 5  #: correct/batch: a recommendation was rejected (deviation beyond the reject band)
NOT_SOLVED = 6  #: correct/batch: a solve was stopped (time limit, solver error) with nothing proven to recommend
REFUSED = 6  #: machine write: refused before any write (stale table, interlock, limit, verdict)
UNCONFIRMED = 7  #: machine write: written but not confirmed (rolled back, or CHECK THE CONTROL)
UNREACHABLE = 8  #: machine read/write, --link: the control could not be reached (nothing written)
