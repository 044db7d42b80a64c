"""Following the drone from the operator's click: gate, confusers, loss and reacquisition."""
