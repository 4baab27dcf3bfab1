"""``kapitza report``: one self-contained folder (HTML page, PNG figures, the GIF, every
table as Parquet and CSV) for the default or a user's scene.
"""
from ._report import SECTIONS, Report, ReportInterrupted, build_report

__all__ = ["build_report", "Report", "ReportInterrupted", "SECTIONS"]
