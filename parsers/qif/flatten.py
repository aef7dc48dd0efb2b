"""All characteristic measurements of a QIF document as plain text records, via XSLT.

Why XSLT: walking tens of thousands of measurement elements from Python creates a
proxy object per element and child, which alone caps the reader well below the
100 000 characteristics/s target; libxslt (through lxml) walks them in C and hands
back one tab-separated line per measurement, which pandas reads as a table.  The stylesheet is fixed, reads only the
given tree and runs with every file and network access denied.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, cast

import pandas as pd
from lxml import etree

__all__ = ["Record", "measurement_table", "record", "results_elements", "COLUMNS"]

#: Where QIF 3 (``Results``), QIF 2.1 and 2.0 (``MeasurementsResults``, with or without a
#: ``MeasurementResultsSet``) keep the parts' results; the stylesheet uses the same path.
RESULTS_XPATH = "/q:QIFDocument/*/q:MeasurementResultsSet/q:MeasurementResults | /q:QIFDocument/*/q:MeasurementResults"

_STYLESHEET = """<xsl:stylesheet version="1.0" xmlns:xsl="http://www.w3.org/1999/XSL/Transform" xmlns:q="{ns}">
<xsl:output method="text" encoding="UTF-8"/>
<xsl:template match="/">
 <xsl:for-each select="{results}">
  <xsl:variable name="r" select="position()"/>
  <xsl:for-each select="q:MeasuredCharacteristics/q:CharacteristicMeasurements/*
                        | q:MeasuredCharacteristics/q:CharacteristicActuals/*">
   <xsl:value-of select="$r"/><xsl:text>&#9;</xsl:text><xsl:value-of select="local-name()"/>
   <xsl:text>&#9;</xsl:text><xsl:value-of select="@id"/>
   <xsl:text>&#9;</xsl:text><xsl:value-of select="count(q:CharacteristicItemId)"/>
   <xsl:text>&#9;</xsl:text><xsl:value-of select="normalize-space(q:CharacteristicItemId)"/>
   <xsl:text>&#9;</xsl:text><xsl:value-of select="normalize-space(q:CharacteristicItemId/@xId)"/>
   <xsl:text>&#9;</xsl:text><xsl:value-of select="count(q:Value)"/>
   <xsl:text>&#9;</xsl:text><xsl:value-of select="normalize-space(q:Value)"/>
   <xsl:text>&#9;</xsl:text><xsl:value-of select="q:Value/@linearUnit"/>
   <xsl:text>&#9;</xsl:text><xsl:value-of select="normalize-space(q:Status/*[1])"/>
   <xsl:text>&#9;</xsl:text>
   <xsl:for-each select="q:FeatureActualIds/q:Id | q:FeatureMeasurementIds/q:Id">
    <xsl:value-of select="normalize-space(.)"/><xsl:text> </xsl:text>
   </xsl:for-each>
   <xsl:text>&#9;</xsl:text><xsl:value-of select="normalize-space(q:Value/@combinedUncertainty)"/>
   <xsl:text>&#10;</xsl:text>
  </xsl:for-each>
 </xsl:for-each>
</xsl:template>
</xsl:stylesheet>"""


@dataclass(frozen=True, slots=True)
class Record:
    """One characteristic measurement.

    Attributes
    ----------
    results : int
        Index of its ``MeasurementResults`` in document order.
    tag : str
        Local element name (``DiameterCharacteristicMeasurement``).
    id : str
        Its ``id`` attribute ("" when absent).
    item : str or None
        Text of ``CharacteristicItemId``; None when the element is missing.
    external : str
        ``xId`` of the item reference ("" for a local item).
    value : str or None
        Text of ``Value``; None when the element is missing.
    unit : str
        ``linearUnit`` of the value ("" for the file unit).
    status : str
        Text of the status enumeration.
    features : str
        Its ``FeatureActualIds`` (QIF 3 also ``FeatureMeasurementIds``), separated by spaces
        ("" when it names none).
    uncertainty : str
        The ``combinedUncertainty`` attribute of its ``Value`` ("" when absent).
    """

    results: int
    tag: str
    id: str
    item: str | None
    external: str
    value: str | None
    unit: str
    status: str
    features: str = ""
    uncertainty: str = ""


@lru_cache(maxsize=8)
def _transform(ns: str) -> etree.XSLT:
    sheet_text = _STYLESHEET.replace("{results}", RESULTS_XPATH)
    text = sheet_text.replace("{ns}", ns) if ns else sheet_text.replace(' xmlns:q="{ns}"', "").replace("q:", "")
    sheet = etree.XML(text.encode())
    return etree.XSLT(sheet, access_control=etree.XSLTAccessControl.DENY_ALL)


def results_elements(root: etree._Element, ns: str) -> list[etree._Element]:
    """The ``MeasurementResults`` elements (one per part) in document order, as the stylesheet sees them."""
    found: list[etree._Element] = (
        root.xpath(RESULTS_XPATH, namespaces={"q": ns}) if ns else root.xpath(RESULTS_XPATH.replace("q:", ""))
    )
    return found


#: Columns of :func:`measurement_table` (the fields of :class:`Record` but ``results``).
COLUMNS = (
    "tag",
    "id",
    "has_item",
    "item",
    "external",
    "has_value",
    "value",
    "unit",
    "status",
    "features",
    "uncertainty",
)


def measurement_table(root: etree._Element, ns: str) -> pd.DataFrame:
    """Every measurement under ``MeasuredCharacteristics``, in document order, as text columns
    (``results`` is the 0-based index of its ``MeasurementResults``)."""
    text = str(_transform(ns)(etree.ElementTree(root)))
    if not text.strip():
        return pd.DataFrame(columns=["results", *COLUMNS])
    frame = pd.read_csv(
        io.StringIO(text),
        sep="\t",
        header=None,
        names=["results", *COLUMNS],
        dtype=str,
        keep_default_na=False,
        quoting=csv.QUOTE_NONE,
        engine="c",
    )
    frame["results"] = frame["results"].astype(int) - 1
    frame["has_item"] = frame["has_item"] != "0"
    frame["has_value"] = frame["has_value"] != "0"
    return frame


def record(frame: pd.DataFrame, index: int) -> Record:
    """Row ``index`` of a :func:`measurement_table` as a :class:`Record`."""
    # The table's index labels are unique, so ``.loc`` gives one row (a Series), never a frame.
    row = cast("pd.Series[Any]", frame.loc[index])
    return Record(
        int(row["results"]),
        row["tag"],
        row["id"],
        row["item"] if row["has_item"] else None,
        row["external"],
        row["value"] if row["has_value"] else None,
        row["unit"],
        row["status"],
        row["features"],
        row["uncertainty"],
    )
