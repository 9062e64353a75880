"""A teaching table from a researcher's own files: the folder format (docs/importing.md), read and checked."""
from .csvlines import TableFolderError
from .folder import TableFolder, read_folder
from .optimality import Optimality, optimality

__all__ = ["Optimality", "TableFolder", "TableFolderError", "optimality", "read_folder"]
