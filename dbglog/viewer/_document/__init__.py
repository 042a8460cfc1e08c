"""The dashboard document: the file format, validation, loading, saving, automatic layouts."""
