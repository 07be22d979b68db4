"""``mgdata annotate``: annotate grasps in the browser with live reachability and collision feedback."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from mgdata.paths import grasps_dir


def register(app: typer.Typer) -> None:
    @app.command("annotate")
    def annotate(
        family: Annotated[str | None, typer.Option(help="Only the objects this family's recipe uses; its "
                                                   "placements drive the live checks.")] = None,
        category: Annotated[str | None, typer.Option(help="Only objects of this category.")] = None,
        obj: Annotated[str | None, typer.Option("--object", help="Start at this model (category/model) "
                                                "instead of where the last session stopped.")] = None,
        port: Annotated[int, typer.Option(help="HTTP port.")] = 8080,
        host: Annotated[str, typer.Option(help="Address to bind (default: this machine only).")
                        ] = "127.0.0.1",
        directory: Annotated[Path | None, typer.Option("--dir", help="Grasp DB folder (default: the "
                                                       "project's grasps/).")] = None,
    ) -> None:
        """Open the grasp annotator in the browser (guided and free modes, live checks, save with Enter).

        Example: mgdata annotate --family jar --category jar --port 8080
        """
        from mgdata.annotator.app import Annotator
        from mgdata.annotator.catalog import Catalog
        from mgdata.annotator.store import GraspStore
        from mgdata.errors import AssetError

        catalog = Catalog.build(family, category)
        if obj is not None and obj not in catalog.keys:
            catalog.index(obj)  # raises with the reason
        if not 0 < port < 65536:
            raise AssetError(f"--port {port}: expected 1 … 65535")
        session = Annotator(catalog, GraspStore(directory or grasps_dir()), host=host, port=port, start=obj)
        actual = session.server.get_port()  # viser moves on to the next free port if this one is taken
        typer.echo(f"annotating {len(catalog.keys)} objects at http://{host}:{actual}/ (Ctrl-C to stop)")
        session.serve_forever()
