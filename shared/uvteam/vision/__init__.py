"""Image processing: UAV motion detection, color landmarks, UGV people detection."""
