"""The paper's reproduction: its dataset specs, published numbers, experiments and report."""
