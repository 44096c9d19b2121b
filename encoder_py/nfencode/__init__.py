"""nfencode: neural-field compression of 3D shapes into `.nfc` files (see libnfdecode/FORMAT.md)."""

__version__ = "0.1.0"
