"""The append-only event timeline and the in-process live hub that pushes changes out."""
