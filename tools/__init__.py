"""towerlink tools package."""
