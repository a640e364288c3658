"""Opening a USD stage: a root layer that cannot be opened is one SceneError line naming the
file; what does not compose (a missing reference, payload or sublayer) is a warning of the
reader's (``warp_st.usd.diagnostics.composition``), and what composed is rendered."""
from __future__ import annotations

import os
import re
import sys
from pathlib import Path

from pxr import Sdf, Tf, Usd

from warp_st.core.native_output import captured_output
from warp_st.core.scene import SceneError
from warp_st.usd.attributes import Where

__all__ = ["open_stage", "tf_message"]


def open_stage(source, *, no_references: bool = False) -> tuple[Usd.Stage, Where]:
    """Open ``source`` (a path or a ``Usd.Stage``); any failure is a one-line SceneError.

    ``no_references=True`` composes only the file's own layer stack (the root layer
    and its sublayers): references and payloads are removed by an explicit empty
    list op authored in the session layer *before* the stage is composed, and
    payloads are not loaded. Best effort: arcs authored inside variants are still
    composed, and a ``Usd.Stage`` passed in is used as already composed. An arc that
    cannot be resolved (a missing referenced file) is left out, and the reader warns.
    """
    with captured_output() as printed:
        if isinstance(source, Usd.Stage):
            root = source.GetRootLayer()
            stage, label = source, root.realPath or root.identifier
        else:
            stage, label = _open_file(os.fspath(source), no_references)
    # USD's own diagnostics of a stage that opened are worth seeing (but not its reports of
    # composition errors: the reader warns of each in one line); those of one that failed
    # are summarised by the SceneError's single line, so they were dropped.
    text = "\n".join(line for line in (printed[0] if printed else "").splitlines()
                     if line.strip() and _COMPOSITION_REPORT not in line)
    if text:
        print(text, file=sys.stderr)
    return stage, Where(label)


#: How USD prints each composition error when a stage opens.
_COMPOSITION_REPORT = "in _ReportErrors at line"


def _open_file(label: str, no_references: bool) -> tuple[Usd.Stage, str]:
    if not Path(label).is_file():
        raise SceneError.at(label, None, None, "no such file")
    try:
        _refresh_open_layer(label)
        if no_references:
            root = Sdf.Layer.FindOrOpen(label)
            stage = Usd.Stage.Open(root, _session_without_arcs(root), Usd.Stage.LoadNone)
        else:
            stage = Usd.Stage.Open(label, Usd.Stage.LoadAll)
    except Tf.ErrorException as exc:
        raise SceneError.at(label, None, None, f"cannot open: {tf_message(exc)}") from None
    except RuntimeError as exc:  # a crate (.usdc) reader failure that is not a Tf error
        raise SceneError.at(label, None, None, f"cannot open: {' '.join(str(exc).split())[:300]}") from None
    if stage is None:
        raise SceneError.at(label, None, None, "cannot open as a USD stage")
    return stage, label


def _refresh_open_layer(label: str) -> None:
    """Read the file as it is on disk now, even if this process still holds it open.

    Sdf keeps one layer per file while any stage uses it (an earlier Scene keeps
    its stage for the camera), so an edited file would otherwise read stale. A
    layer with unsaved in-memory edits is left alone.
    """
    layer = Sdf.Layer.Find(label)
    if layer is not None and not layer.dirty:
        layer.Reload(force=True)


def tf_message(exc: Exception) -> str:
    """The first quoted message of a Tf error, on one line (the parser's is the most precise)."""
    messages = []
    if isinstance(exc, UnicodeDecodeError):
        return "the file holds text that is not UTF-8"
    try:
        text = str(exc)
    except UnicodeDecodeError:  # USD quotes the offending bytes, and they are not UTF-8
        return "parse error (the file holds bytes that are not UTF-8 text)"
    for chunk in re.split(r"\bError in\b", text):
        start, end = chunk.find(" : '"), chunk.rfind("'")
        if 0 <= start < end:
            messages.append(chunk[start + 4:end])
    text = messages[0] if messages else text
    return " ".join(text.split())


def _session_without_arcs(root: Sdf.Layer) -> Sdf.Layer:
    """A session layer whose explicit empty references / payloads hide every such arc of the layer stack."""
    session = Sdf.Layer.CreateAnonymous("no-references-session.usda")
    seen, layers = set(), [root]
    while layers:
        layer = layers.pop()
        if layer is None or layer.identifier in seen:
            continue
        seen.add(layer.identifier)
        layers.extend(Sdf.Layer.FindOrOpenRelativeToLayer(layer, p) for p in layer.subLayerPaths)

        def visit(path, layer=layer):
            if not path.IsPrimPath() or path.ContainsPrimVariantSelection():
                return
            spec = layer.GetPrimAtPath(path)
            if spec is None or not (spec.hasReferences or spec.hasPayloads):
                return
            over = Sdf.CreatePrimInLayer(session, path)
            over.referenceList.ClearEditsAndMakeExplicit()
            over.payloadList.ClearEditsAndMakeExplicit()

        layer.Traverse(Sdf.Path.absoluteRootPath, visit)
    return session
