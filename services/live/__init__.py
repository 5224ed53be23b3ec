"""What the API needs from the live system (protocols) and their implementation over Zenoh."""
