"""Files: atomic writes, the npz reader and run folders. Imports nothing of the package."""
