"""The ARKit face vocabulary every part shares: the 52 blendshape names in Live Link Face's
order (``blendshapes``) and the head-rotation convention (``rotation``).

Pure NumPy, at the bottom of the layers: the worker's frames and capture sources, the
Python face tracker (``chameleons.facemesh``) and the analysis import it, and it imports
nothing of the project.
"""
