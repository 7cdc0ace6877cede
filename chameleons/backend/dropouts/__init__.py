"""Dropouts without deleting data: excluding a participant from the analysis, and handing a
dropout's plan row to a replacement participant."""
