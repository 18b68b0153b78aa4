#!/usr/bin/env python3
"""Takes docs/opcua-client.png: FreeOpcUa's client GUI (opcua-client, on asyncua
and PyQt5; not a client of ours) browsing a running plant's address space, a
line's State selected and every line's State subscribed. Run by
scripts/docs/opcua-screenshot.js, which starts the plant:

    usage: opcua_screenshot.py <endpoint url> <namespace uri> <png path>

Qt draws offscreen (QT_QPA_PLATFORM=offscreen): no display is needed. The
caller gives it a fresh XDG_CONFIG_HOME: no settings from an earlier run.
"""
import os
import sys
import time

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

from PyQt5.QtCore import QCoreApplication, Qt  # noqa: E402
from PyQt5.QtWidgets import QApplication  # noqa: E402
from uaclient.mainwindow import Window  # noqa: E402

LINES = ["YEL", "GRN", "BLU", "PUR", "RED"]


def pump(seconds):
    """Lets Qt draw and the subscriptions' notifications arrive."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        QCoreApplication.processEvents()
        time.sleep(0.05)


def open_path(window, names):
    """Expands the tree along browse names (Root, Objects, Plant, ...) and selects the last."""
    view, model = window.ui.treeView, window.tree_ui.model
    item = model.item(0)
    for name in names[1:]:
        index = model.indexFromItem(item)
        if model.canFetchMore(index):
            model.fetchMore(index)
        view.setExpanded(index, True)
        rows = [item.child(r, 1) for r in range(item.rowCount())]
        found = next((r for r in rows if r.text().split(":", 1)[-1] == name), None)
        if found is None:
            raise SystemExit(f"{name} not under {item.text()}: {[r.text() for r in rows]}")
        item = item.child(found.row(), 0)
    view.setCurrentIndex(model.indexFromItem(item))


def main(url, ns_uri, out):
    app = QApplication(sys.argv[:1])
    window = Window()
    window.resize(1280, 760)
    window.ui.logDockWidget_2.hide()
    window.ui.addrComboBox.setEditText(url)
    window.show()
    window.connect()
    client = window.uaclient.client
    ns = client.get_namespace_index(ns_uri)
    node = lambda path: client.get_node(f"ns={ns};s={path}")  # noqa: E731
    subscribed = [f"Lines/{line}/{v}" for line in LINES for v in ("State", "Holder")] + ["Queue/Length"]
    for row, path in enumerate(subscribed):
        window.datachange_ui._subscribe(node(path))
        window.datachange_ui.model.item(row, 0).setText(path)  # the GUI shows a display name: State five times
    open_path(window, ["Root", "Objects", "Plant", "Lines", "BLU", "FaultNote"])
    window.show_attrs(None)
    window.ui.subDockWidget.raise_()
    window.ui.treeView.setColumnWidth(0, 230)
    window.resizeDocks([window.ui.attrDockWidget], [820], Qt.Horizontal)
    window.resizeDocks([window.ui.attrDockWidget, window.ui.subDockWidget], [300, 420], Qt.Vertical)
    pump(3)
    window.ui.attrView.setColumnWidth(0, 150)
    window.ui.attrView.setColumnWidth(1, 430)
    window.ui.attrView.scrollToBottom()  # the Value attribute, the last of them
    pump(0.5)
    if not window.grab().save(out):
        raise SystemExit(f"could not write {out}")
    window.disconnect()
    app.quit()


if __name__ == "__main__":
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    main(*sys.argv[1:])
