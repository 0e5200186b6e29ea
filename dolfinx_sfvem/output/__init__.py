"""What a run writes and says: files, pictures, summaries, messages."""
