"""Image processing: UAV motion detection, colour landmarks, UGV people detection."""
