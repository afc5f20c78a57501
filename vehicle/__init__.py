"""towerlink vehicle package."""
