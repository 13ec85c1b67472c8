"""wsmap: manipulator workspace maps, classical and learned.

A reproduction and extension of P. Liao, "Deep Neural Network Based Subspace Learning of Robotic
Manipulator Workspace Mapping". See README.md for the conventions and the paper's numbers.
"""

__version__ = "0.1.0"
