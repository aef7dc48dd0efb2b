"""Use case "model map": answer a scaffold's questions — which work offset and which tool made each feature.

A multi-axis ``model init`` scaffold (:mod:`setupfix.outputs.model_toml`) leaves every
feature an offset could move without a relation and with a named question in its
``note`` (``question Q3: which work offset (WKS) and which tool made it?``; a size cut by
interpolation: ``question Q3: which tool cut it? (radius weight -2)``).  The features of
one part feature (its location and its sizes) share one question.

:func:`map_listing` lists the open questions with each feature's position and the
callouts it enters; :func:`answer_questions` writes answers into the model text:

* a located feature gets ``wks = { W = 1 }`` (the work offset moves it in every axis)
  and, where a dimension it enters is measured with a component along the spindle (a
  face whose normal is the spindle axis, a depth), ``tools = { T = 1 }``: its tool's
  length moves it along the spindle;
* a size feature gets ``radius = { T = w }`` with the weight its question states;
* an answer naming a work offset or tool the model does not declare adds its table
  (``[wks.W2] register = "G55"``; ``[tools.T5] register = "H5"`` and ``radius = "D5"``
  where a size needs it);
* the question's ``note`` goes; when none is left ``draft = true`` goes too (unless
  ``keep_draft``), so ``correct`` no longer holds.

Answers select questions by name (``Q3``), feature ID (``F3``), the report's feature name
(``CYLINDER2``), a callout name (``DIAMETER5``) or a pattern over those (``DIAMETER5*``),
a station (``group:P1``: the features of its dimensions), or ``*`` (every open one), so
features sharing a tool or a station are answered as a group.  A narrower answer wins:
a group, a pattern and ``*`` answer only what no narrower answer (in that order) did;
two answers of one breadth that disagree on a question are refused.  The text is edited line
by line (comments and the user's other edits stay), checked by loading it, and written
atomically; nothing is written when any answer is refused.
"""

from setupfix.usecases.model_map.answers import (
    NONE_WORDS,
    Answer,
    MapResult,
    answer_questions,
    answer_text,
    parse_answer,
    read_answers,
)
from setupfix.usecases.model_map.listing import MapFeature, MapListing, Question, map_listing

__all__ = [
    "MapFeature",
    "Question",
    "MapListing",
    "Answer",
    "MapResult",
    "map_listing",
    "read_answers",
    "parse_answer",
    "answer_questions",
    "answer_text",
    "NONE_WORDS",
]
