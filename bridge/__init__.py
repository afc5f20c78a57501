"""towerlink bridge package."""
