"""Outputs only, made from an engine.pipeline Run: results (JSON, CSV), QIF, figures, the PDF
certificate, its signing, the files written all or none (outputs), and the words for the user."""
