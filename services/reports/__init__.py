"""Clinical reports of a trial: normative data, the report's content from the stored results, the PDF."""
