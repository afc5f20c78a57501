"""towerlink gcs package."""
