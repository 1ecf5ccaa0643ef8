"""Per-chapter assembly: stage results in, the chapter's tables and figures out."""
